"""The failing example Hypothesis reported, from an exception or a report's text."""

from __future__ import annotations

import re

__all__ = ["falsifying_example"]

_FRAME = re.compile(r"^(?:\s*\|(?: |$))+")

_EXAMPLE_HEADS = ("Falsifying example:", "Failing test case:")  # Hypothesis's wordings


def falsifying_example(failure: BaseException | str) -> str | None:
    """The failing example Hypothesis reported, from the exception's notes or a report text.

    Returns the call Hypothesis prints (``Failing test case: test_x(speed=1.5, ...)``), or
    None for a failure that did not come from Hypothesis. When Hypothesis found several
    distinct failures (an ExceptionGroup), their examples are returned one after the other.
    """
    if isinstance(failure, BaseException):
        found = list(dict.fromkeys(_examples(failure)))
        return "\n".join(found) if found else None
    # A report text: pytest prefixes exception lines with "E   ", an ExceptionGroup's
    # traceback frames each sub-exception's lines with "|".
    lines = [_FRAME.sub("", line.removeprefix("E   ")) for line in failure.splitlines()]
    blocks: list[str] = []
    for i, line in enumerate(lines):
        if not line.startswith(_EXAMPLE_HEADS):
            continue
        block = [line]
        if line.rstrip().endswith("("):  # the call spans lines up to its closing parenthesis
            for following in lines[i + 1 :]:
                block.append(following)
                if following.startswith(")"):
                    break
        blocks.append("\n".join(block).strip())
    found = list(dict.fromkeys(blocks))
    return "\n".join(found) if found else None


def _examples(error: BaseException) -> list[str]:
    out = [
        note.strip()
        for note in getattr(error, "__notes__", ())
        if isinstance(note, str) and note.startswith(_EXAMPLE_HEADS)
    ]
    if isinstance(error, BaseExceptionGroup):
        for inner in error.exceptions:
            out.extend(_examples(inner))
    return out
