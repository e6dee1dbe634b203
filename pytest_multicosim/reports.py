"""What the reports say about a test of ours: the header line, the verdict, how to replay it.

A failing test gets a ``multicosim`` report section: a one-line verdict (for a requirement,
where it was first violated), the command that replays it with the same seed, fidelity and
placement, the saved artifacts and the last output of each component. JUnit XML (and other
report readers) get the same facts as the test's ``user_properties``.
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import pytest

from .artifacts import artifacts_dir, dest_key, save_logs, save_trace, trace_key
from .fidelity import fidelity_of
from .options import FIRMWARE_DESTS, Settings, settings_key, sourced
from .simulations import view_key

__all__ = ["annotate", "header", "replay_command", "verdict"]

_KINDS = {".mcap": "trace", ".json": "layout", ".tlog": "mavlink", ".png": "plot"}


def header(config: pytest.Config) -> str:
    """The session's header line: the selected fidelity, placement, seed and artifacts."""
    s = config.stash[settings_key]
    return (
        f"multicosim: fidelity={','.join(s.fidelity)} placement={s.placement or 'default'} "
        f"seed={s.seed} "
        f"keep-traces={s.keep_traces} artifacts={s.artifacts}"
    )


def replay_command(settings: Settings, item: pytest.Item) -> str:
    """The command that runs ``item`` again with the same seed, fidelity and placement.

    The test is named by its absolute path and pytest by the interpreter that runs this
    session (``/path/to/python -m pytest``), so the command works from any directory, with
    or without the virtual environment activated.
    """
    _, sep, rest = item.nodeid.partition("::")
    target = str(item.path) + (sep + rest if sep else "")
    # Quoted for a POSIX shell: parametrized ids may hold quotes, spaces or brackets.
    pytest_cmd = f"{shlex.quote(sys.executable)} -m pytest"
    config = item.config
    # The same root (so the same test id and ini file from any directory), and the firmware
    # this run found in options, ini or environment, which another shell may not have.
    extra = [f"--rootdir={shlex.quote(str(config.rootpath))}"]
    for dest in FIRMWARE_DESTS:
        value = sourced(config, dest)
        if value is not None:
            path = Path(value)
            shown = str(path.absolute()) if path.exists() else value
            extra.append(f"--{dest.replace('_', '-')}={shlex.quote(shown)}")
    args = settings.replay_args(fidelity_of(item))
    return f"{pytest_cmd} {shlex.quote(target)} {' '.join(extra)} {args}"


def verdict(item: pytest.Item, call: pytest.CallInfo[None]) -> str:
    """One line: what failed, and for a requirement where it was first violated."""
    if call.excinfo is None:
        return "failed"
    text = call.excinfo.exconly().strip().splitlines()
    line = text[0] if text else call.excinfo.typename
    test_trace = item.stash.get(trace_key, None)
    evaluation = getattr(test_trace, "evaluation", None)
    first = getattr(evaluation, "first_violation", None)
    if first is not None and "first violated at" not in line:
        line += f"; first violated at t={first:.6g} s"
    return line


def _properties(item: pytest.Item, settings: Settings, replay: str, saved: list[Path]) -> None:
    found = [("mcs_seed", str(settings.seed)), ("mcs_replay", replay)]
    found.extend((f"mcs_{_KINDS.get(p.suffix, 'file')}", str(p)) for p in saved)
    item.user_properties.extend(p for p in found if p not in item.user_properties)


def annotate(item: pytest.Item, call: pytest.CallInfo[None], report: pytest.TestReport) -> None:
    """Save ``item``'s artifacts as the settings say; on failure add the report section."""
    settings = item.config.stash[settings_key]
    fidelity = fidelity_of(item)
    replay = replay_command(settings, item)
    dest = item.stash.get(dest_key, None) or artifacts_dir(settings, item)
    keep = settings.keep_traces != "none"
    saved: list[Path] = []
    if not report.failed:
        # --mcs-keep-traces=all keeps what passing tests left too (without a report section).
        if settings.keep_traces == "all" and report.when == "call":
            passed_view = item.stash.get(view_key, None)
            if passed_view is not None:
                save_logs(passed_view, dest)
            saved, _ = save_trace(item, call, dest, replay)
            _properties(item, settings, replay, saved)
        return
    problem = None
    if keep and report.when in ("setup", "call"):
        saved, problem = save_trace(item, call, dest, replay)
    # JUnit XML (and other report readers) get the same facts as properties; they are read
    # from the item when the teardown report is made.
    _properties(item, settings, replay, saved)
    lines = [f"verdict: {verdict(item, call)}", f"replay: {replay}"]
    lines.extend(f"{_KINDS.get(path.suffix, 'file')}: {path}" for path in saved)
    if problem is not None:
        lines.append(f"trace: not saved ({problem})")
    mcap = next((p for p in saved if p.suffix == ".mcap"), None)
    layout = next((p for p in saved if p.suffix == ".json"), None)
    if mcap is not None and layout is not None:
        lines.append(
            f"open: Foxglove (app or web) > Open local file... {mcap.name}, then "
            f"Layout > Import from file... {layout.name}"
        )
    lines.append(
        f"seed {settings.seed}, fidelity {fidelity or ','.join(settings.fidelity)}, "
        f"placement {settings.placement_for(fidelity)}"
    )
    view = item.stash.get(view_key, None)
    if view is not None and keep:
        for name, (path, tail) in save_logs(view, dest).items():
            where = f"full log: {path}" if path is not None else "full log not saved"
            lines.append(f"--- {name}: last output ({where}) ---")
            lines.append(tail)
    report.sections.append(("multicosim", "\n".join(lines)))
