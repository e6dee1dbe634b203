"""A falsification's traces are a failing test's: the run's channels and the vehicle's path."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from matplotlib.patches import Rectangle

import multicosim.attacks as attacks
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.search.falsify import FalsificationResult, falsify
from multicosim.trace import read_trace
from multicosim.trace._plot import figure

HOME = px4.Home()
MISSION = px4.Configuration([px4.Waypoint(lat=47.3980, lon=8.5460, alt=25.0)], end="hold")


def simulate(sample: dict[str, float], fidelity: str, seed: int) -> dict[str, list[float]]:
    """PX4 under a GPS spoof, started as a user would (no fixture, no recorder of its own)."""
    simulator = px4.PX4(fidelity=fidelity, seed=seed)  # type: ignore[arg-type]
    spoof = attacks.Jump(offset=attacks.Local(north=sample["north"]), start=sample["start"])
    attacks.inject(simulator, "gps", [spoof])
    with simulator.start() as simulation:
        result = simulation.firmware.send(MISSION)
    projection = LocalProjection(HOME.lat, HOME.lon)
    north = [projection.project(s.true_lat, s.true_lon)[0] for s in result.trajectory]
    return {"time": [s.time for s in result.trajectory], "north": north}


def search(seed: int, trace_dir: Path | None = None) -> FalsificationResult:
    """A spoof 15-20 m south makes PX4 fly as far past its waypoint, 25 m north: a violation."""
    return falsify(
        simulate,
        "always (north <= 35)",
        {"north": (-20.0, -15.0), "start": (5.0, 10.0)},
        optimizer="random",
        levels="low",
        budget=3,
        seed=seed,
        trace_dir=trace_dir,
    )


def test_a_px4_counterexample_trace_holds_the_runs_channels_and_its_path(
    tmp_path: Path,
) -> None:
    result = search(1, tmp_path / "traces")
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx is not None
    mcap = next(p for p in cx.results["low"].traces if p.suffix == ".mcap")
    trace = read_trace(mcap)
    # What a failing test's trace of the same run holds: the firmware's and the world's
    # channels, the Foxglove ones the PX4 scenario derives, the requirement's.
    assert {
        "px4/gps",
        "px4/gps/attacked",
        "px4/truth",
        "px4/mavlink/down/GLOBAL_POSITION_INT",
        "px4/location/truth",
        "mcs/path/estimate",
        "mcs/path/truth",
        "mcs/plan",
        "mcs/trajectory",
        "mcs/robustness",
        "mcs/attack",
    } <= set(trace.channels)
    ax_path, ax_signals, ax_rob = figure(trace).axes
    # The spoof's window is shaded where the signals and the margin are drawn.
    for ax in (ax_signals, ax_rob):
        (window,) = [p for p in ax.patches if p.get_gid() == "attack/gps/Jump"]
        assert window.get_label() == "attack: Jump on gps"
        assert isinstance(window, Rectangle)
        assert window.get_x() == cx.example["start"]
    lines: dict[Any, Any] = {line.get_gid(): line for line in ax_path.get_lines()}
    assert ax_path.get_title().startswith("path")
    assert max(lines["path/truth"].get_ydata()) > 35  # north past the bound, drawn

    # The counterexample says how to replay it: sample, level, seed, and a test to run.
    assert cx.seed == 1
    assert f"simulate({cx.example!r}, 'low', 1)" in cx.replay
    assert "python -m pytest test_counterexample.py" in cx.replay
    assert "replay it as a test:" in result.summary()
    test_file = tmp_path / "test_counterexample.py"
    test_file.write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "from test_search_traces import simulate\n" + cx.replay
    )
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test_file)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 1, run.stdout + run.stderr
    assert "1 failed" in run.stdout
    assert "RequirementViolation" in run.stdout


FALSIFICATION_TEST = """
from test_search_traces import search


def test_no_spoof_pulls_px4_past_35_m(mcs_seed):
    search(mcs_seed).assert_holds()
"""


def test_a_failing_falsification_test_keeps_the_violating_runs_trace(
    pytester: pytest.Pytester,
) -> None:
    pytester.makepyfile(test_inner=FALSIFICATION_TEST)
    result = pytester.runpytest("--mcs-artifacts=arts", "--mcs-seed=1", "-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*replay it as a test:*", "trace: *trace.mcap"])
    (mcap,) = (pytester.path / "arts").rglob("trace.mcap")
    trace = read_trace(mcap)
    assert {"px4/gps/attacked", "mcs/path/truth", "mcs/attack", "mcs/robustness"} <= set(
        trace.channels
    )
    assert float(trace.info["robustness"]) < 0
