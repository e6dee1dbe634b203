"""The artifacts directory fills up while a failing test's trace is saved (a small tmpfs).

The test's verdict and report stay intact: the report says the trace could not be written,
and no truncated trace (nor a temporary file) is left where a reader would take it for one.
"""

from __future__ import annotations

import errno
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fault_helpers import Detections, failing

import multicosim as mcs
import multicosim.rover as rover
from multicosim import trace

DISK = 1 << 20  # bytes: the tmpfs
FREE = 16 << 10  # bytes left free before the save: less than the trace needs

# A failing medium-fidelity test (the rover's MuJoCo world and its controller, processes)
# whose trace is larger than what is left of the artifacts' disk.
FAILING = """
import pytest
import multicosim.rover as rover


@pytest.mark.fidelity("medium")
def test_rover_drives_backwards(rover_simulation):
    trajectory = rover_simulation.controller.send(rover.Mission(speed=5.0))
    assert trajectory.final.x < 0, "the rover drove forwards"
"""


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A tmpfs of DISK bytes, mounted for the test (needs root), filled but for FREE."""
    mount = tmp_path / "disk"
    mount.mkdir()
    command = ["mount", "-t", "tmpfs", "-o", f"size={DISK},mode=0700", "tmpfs", str(mount)]
    try:
        subprocess.run(command, check=True, capture_output=True, timeout=30)
    except (OSError, subprocess.SubprocessError) as exc:
        pytest.skip(f"a tmpfs cannot be mounted here (mount needs root): {exc}")
    try:
        with open(mount / "filler", "wb") as filler:
            filler.write(b"\0" * (DISK - FREE))
        yield mount
    finally:
        subprocess.run(["umount", "--lazy", str(mount)], check=True, timeout=30)


def _left_behind(root: Path) -> list[Path]:
    """Traces, and temporary files of writes that failed, under ``root``."""
    return sorted(p for p in root.rglob("*") if p.suffix in (".mcap", ".part"))


def test_full_artifacts_disk_keeps_the_report_intact(
    pytester: pytest.Pytester, small_disk: Path
) -> None:
    pytester.makepyfile(test_inner=FAILING)
    artifacts = small_disk / "artifacts"
    artifacts.mkdir()
    result = pytester.runpytest_subprocess(
        "-p", "no:cacheprovider", "--mcs-fidelity=medium", f"--mcs-artifacts={artifacts}"
    )
    result.assert_outcomes(failed=1)  # the test's own failure, not an error of the harness
    result.stdout.fnmatch_lines(
        [
            "verdict: AssertionError: the rover drove forwards*",
            "replay: * -m pytest *test_inner.py::test_rover_drives_backwards*",
            "trace: not saved (TraceError: could not write the trace *No space left on device*)",
        ]
    )
    assert _left_behind(small_disk) == []


def test_full_disk_trace_error_and_its_detection_time(
    small_disk: Path, detections: Detections
) -> None:
    # The same save, timed: from the start of the write that fills the disk to its error.
    recording = trace.TestTrace()
    simulator = rover.Rover(fidelity="medium", seed=1)
    with simulator.start() as simulation:
        recording.attach(simulation.simulation)
        simulation.controller.send(rover.Mission(speed=5.0))
    started = time.monotonic()
    error, error_at = failing(lambda: recording.save(small_disk / "artifacts"), mcs.TraceError)
    cause = error.__cause__
    assert isinstance(cause, OSError)
    assert cause.errno == errno.ENOSPC
    assert _left_behind(small_disk) == []
    detections.record("artifacts disk full while saving a trace", started, error_at, 0.0, error)
