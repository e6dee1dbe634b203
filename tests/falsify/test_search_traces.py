"""A falsification's traces are a failing test's: the run's channels and the vehicle's path."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import multicosim.attacks as attacks
import multicosim.px4 as px4
from multicosim.falsify import falsify
from multicosim.geo import LocalProjection
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


def test_a_px4_counterexample_trace_holds_the_runs_channels_and_its_path(
    tmp_path: Path,
) -> None:
    # A spoof 15-20 m south makes PX4 fly as far past its waypoint, 25 m north: a violation.
    result = falsify(
        simulate,
        "always (north <= 35)",
        {"north": (-20.0, -15.0), "start": (5.0, 10.0)},
        optimizer="random",
        levels="low",
        budget=3,
        seed=1,
        trace_dir=tmp_path / "traces",
    )
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
    } <= set(trace.channels)
    ax_path = figure(trace).axes[0]
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
