"""``python -m multicosim.docker build|sweep``: the same as ``multicosim images build`` and
``multicosim sweep`` (which also removes leftover processes)."""

from __future__ import annotations

import sys

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point: hands over to the ``multicosim`` command."""
    from ..__main__ import main as multicosim

    args = sys.argv[1:] if argv is None else list(argv)
    options = [a for a in args if a in ("-v", "--verbose")]
    rest = [a for a in args if a not in options]
    if rest[:1] == ["build"]:
        return multicosim([*options, "images", *rest])
    return multicosim([*options, *rest])


if __name__ == "__main__":
    sys.exit(main())
