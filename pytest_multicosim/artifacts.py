"""What a test leaves for its diagnosis: its trace, plots and the components' logs.

Each test of ours records a trace from its first fixture's setup to its last teardown; when
it fails (or with ``--mcs-keep-traces=all``) the trace, its Foxglove layout, plots, the
components' output and real firmware's flight logs are written to one directory per test,
seed and placement under ``--mcs-artifacts``.
"""

from __future__ import annotations

import contextlib
import logging
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from multicosim.core.errors import MulticosimError
from multicosim.core.files import replacing

from .fidelity import fidelity_of
from .options import Settings, settings_key
from .simulations import Simulations

__all__ = [
    "artifacts_dir",
    "dest_key",
    "recording",
    "save_logs",
    "save_trace",
    "trace_key",
]

log = logging.getLogger(__name__)

trace_key = pytest.StashKey[Any]()
"""Where an item's stash keeps its ``multicosim.trace.TestTrace``."""
dest_key = pytest.StashKey[Path]()
"""Where an item's stash keeps its artifacts directory."""

_FLIGHT_LOG_VIEWERS = {
    ".ulg": "(ULog: open it in PX4's Flight Review)",
    ".BIN": "(DataFlash log: open it in MAVExplorer or UAV Log Viewer)",
}


def _slug(nodeid: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", nodeid).strip("_")[:150]


def artifacts_dir(settings: Settings, item: pytest.Item) -> Path:
    """Where the artifacts of ``item`` go: one directory per test, seed and placement.

    A replay with another seed (or placement) writes beside the original failure's files, not
    over them.
    """
    run = f"seed-{settings.seed}-{settings.placement_for(fidelity_of(item))}"
    return settings.artifacts / _slug(item.nodeid) / run


@contextlib.contextmanager
def recording(item: pytest.Item) -> Iterator[None]:
    """Record ``item``'s trace while the block runs (its setup, call and teardown)."""
    from multicosim import trace

    settings = item.config.stash[settings_key]
    dest = artifacts_dir(settings, item)
    # What an earlier run of this test left must not pass for this run's.
    shutil.rmtree(dest, ignore_errors=True)
    item.stash[dest_key] = dest
    test_trace = trace.TestTrace(
        metadata={
            "test": item.nodeid,
            "seed": settings.seed,
            "fidelity": fidelity_of(item) or settings.fidelity[0],
            "placement": settings.placement_for(fidelity_of(item)),
        },
        # A repeated test is compared sample by sample, whatever is kept of it.
        record=settings.keep_traces != "none" or settings.repeat > 1,
    )
    item.stash[trace_key] = test_trace
    with trace.activate(test_trace):
        yield


def save_trace(
    item: pytest.Item, call: pytest.CallInfo[None], dest: Path, replay: str
) -> tuple[list[Path], str | None]:
    """Save the test's traces; return the written paths, or why nothing could be written."""
    test_trace = item.stash.get(trace_key, None)
    if test_trace is None:
        return [], None
    from multicosim import trace

    example = None
    if call.excinfo is not None:
        example = trace.falsifying_example(call.excinfo.value)
    # The recording ends with the call: what teardown routes is not part of the failure.
    test_trace.detach()
    try:
        saved: list[Path] = test_trace.save(dest, failing_example=example, replay=replay)
    except Exception as exc:  # a trace is a diagnosis aid: never turn a report into a crash
        log.warning("could not save the trace of %s: %s", item.nodeid, exc)
        return [], f"{type(exc).__name__}: {exc}"
    return saved, None


def save_logs(view: Simulations, dest: Path) -> dict[str, tuple[Path | None, str]]:
    """Copy the output of ``view``'s simulations to ``dest``: name -> (copy, what to show).

    A copy that cannot be written (a full disk) leaves no partial file: its entry has no
    path, and what to show says why, after the output's tail.
    """
    saved: dict[str, tuple[Path | None, str]] = {}
    for sim in view.simulations:
        logs = getattr(sim, "logs", None)
        if logs is None:
            continue
        try:
            files = logs()
        except (OSError, MulticosimError):
            continue
        for name, path in files.items():
            try:
                tail = "\n".join(path.read_text(errors="replace").splitlines()[-20:])
            except OSError:
                continue
            saved[name] = _copy(path, dest, tail)
        # Real firmware's flight logs (binary: copied, not shown): PX4's ULog files, for its
        # Flight Review; ArduPilot's DataFlash logs, for MAVExplorer or UAV Log Viewer.
        flight_logs = getattr(sim, "flight_logs", None)
        try:
            ulogs = flight_logs() if flight_logs is not None else []
        except (OSError, MulticosimError):
            ulogs = []
        for path in ulogs:
            viewer = _FLIGHT_LOG_VIEWERS.get(path.suffix, "(a flight log)")
            saved[f"flight log {path.name}"] = _copy(path, dest, viewer)
    return saved


def _copy(path: Path, dest: Path, text: str) -> tuple[Path | None, str]:
    target = dest / path.name
    try:
        with replacing(target) as temporary:
            shutil.copyfile(path, temporary)
    except OSError as exc:
        return None, f"{text}\n(not saved: {exc})"
    return target, text
