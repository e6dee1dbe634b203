"""Falsification regression suite: Hypothesis searches GPS attacks against a requirement.

The requirement: the PX4 autopilot's position estimate stays within 5 m of the truth
(``always (error <= 5)``). Small GPS noise never breaks it (Hypothesis finds nothing in its
budget); a spoof does, and the search shrinks it to the smallest one that does. A failing
property leaves an MCAP trace and a PNG plot in ``--mcs-artifacts``::

    pytest scenarios/test_falsification.py --mcs-fidelity=low
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import multicosim.attacks as attacks
import multicosim.px4 as px4
import multicosim.search.strategies as mst
from multicosim.attacks import strategies as ast
from multicosim.core.geo import LocalProjection
from multicosim.search.falsify import HypothesisSearch, falsify
from multicosim.search.requirements import Requirement

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
LIMIT = 5.0  # m between estimate and truth
SEARCH_BUDGET = 25


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


MISSION = px4.Configuration([wp(0, 40, 10)], end="hold")


def estimate_error(s: Any) -> Any:
    """Horizontal distance (m) between the autopilot's estimate and the world's truth."""
    projection = LocalProjection(HOME.lat, HOME.lon)
    estimate = [projection.project(lat, lon) for lat, lon in zip(s["lat"], s["lon"], strict=True)]
    truth = [projection.project(*p) for p in zip(s["true_lat"], s["true_lon"], strict=True)]
    north, east = (np.asarray(estimate) - np.asarray(truth)).T
    return np.hypot(north, east)


TRACKING = Requirement(
    f"always (error <= {LIMIT:g})", derived={"error": estimate_error}, name="tracking"
)


def attacked_px4(
    fidelity: str = "low", seed: int = 0, models: tuple[attacks.Model, ...] = ()
) -> px4.PX4:
    """A PX4 simulator whose GPS goes through an injector with ``models``."""
    simulator = px4.PX4(fidelity=fidelity, seed=seed)  # type: ignore[arg-type]
    attacks.inject(simulator, "gps", list(models))
    return simulator


def horizontal_spoofs(max_offset: int = 20) -> st.SearchStrategy[attacks.Jump]:
    """A horizontal GPS spoof of whole metres towards one of eight bearings, from 3 to 10 s.

    Whole metres and seconds keep shrinking short: a failure ends at the smallest offset.
    """

    def build(metres: int, bearing: int, start: int) -> attacks.Jump:
        b = math.radians(bearing)
        return attacks.Jump(
            offset=attacks.Local(east=metres * math.sin(b), north=metres * math.cos(b)), start=start
        )

    return st.builds(
        build,
        st.integers(0, max_offset),
        st.sampled_from(range(0, 360, 45)),
        st.integers(3, 10),
    )


@pytest.mark.fidelity("low")
@settings(max_examples=SEARCH_BUDGET, deadline=None, database=None, derandomize=True)
@given(noise=ast.gaussians((0.0, 1.0)), drift=ast.drifts((0.0, 0.1)))
def test_small_gps_noise_never_breaks_tracking(
    mcs_fresh_simulation: Any, noise: attacks.Gaussian, drift: attacks.Drift
) -> None:
    with mcs_fresh_simulation(attacked_px4, models=(noise, drift)) as simulation:
        result = simulation.firmware.send(MISSION)
    assert result.completed, result.reason
    mst.target_robustness(TRACKING.evaluate(result.trajectory))
    TRACKING.check(result.trajectory)


@pytest.mark.fidelity("low")
def test_gps_spoof_breaks_tracking_and_shrinks_to_the_limit(mcs_seed: int) -> None:
    def run(spoof: attacks.Jump, fidelity: str, seed: int) -> Any:
        with attacked_px4(fidelity, seed, (spoof,)).start() as simulation:
            return simulation.firmware.send(MISSION).trajectory

    result = falsify(
        run,
        TRACKING,
        horizontal_spoofs(),
        optimizer=HypothesisSearch(shrink=True),
        levels=("low",),
        budget=SEARCH_BUDGET,
        seed=mcs_seed,
    )
    assert result.falsified, result.summary()
    assert result.counterexample is not None
    spoof = result.counterexample.example
    assert isinstance(spoof.offset, attacks.Local)
    size = math.hypot(spoof.offset.north, spoof.offset.east)
    # Shrunk to the limit: the estimate follows the spoof (overshooting it a little), so the
    # error is about the offset and the smallest spoof that breaks the requirement is ~5 m.
    assert size == pytest.approx(LIMIT, abs=1.01), result.summary()
    low = result.counterexample.results["low"]
    assert -1.5 < low.evaluation.robustness < 0


FAILING_PROPERTY = """
from hypothesis import Phase, given, settings

import multicosim.search.strategies as mst
from gps_falsification import MISSION, TRACKING, attacked_px4, horizontal_spoofs

# No explain phase: it re-runs the minimal example with parts varied, simulations each.
PHASES = [Phase.explicit, Phase.generate, Phase.target, Phase.shrink]


@settings(max_examples=20, database=None, derandomize=True, deadline=None, phases=PHASES)
@given(spoof=horizontal_spoofs())
def test_spoofs_keep_tracking(mcs_fresh_simulation, spoof):
    with mcs_fresh_simulation(attacked_px4, models=(spoof,)) as simulation:
        result = simulation.firmware.send(MISSION)
    mst.target_robustness(TRACKING.evaluate(result.trajectory))
    TRACKING.check(result.trajectory)
"""


@pytest.mark.fidelity("low")
def test_a_failing_spoof_property_leaves_a_trace_and_a_plot(pytester: pytest.Pytester) -> None:
    from multicosim.trace import read_trace

    pytester.makepyfile(gps_falsification=Path(__file__).read_text())
    pytester.makepyfile(test_spoof=FAILING_PROPERTY)
    result = pytester.runpytest(
        "-p", "no:cacheprovider", "--mcs-fidelity=low", "--mcs-artifacts=artifacts"
    )
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "*requirement 'always (error <= 5)' is violated*",
            "*: test_spoofs_keep_tracking(",
            "*spoof=build(5, 0, 3),",  # shrunk: 5 m north from 3 s
            "replay: * -m pytest *test_spoof.py::test_spoofs_keep_tracking* --mcs-seed=0*",
            "trace: */test_spoof.py_test_spoofs_keep_tracking_low/seed-0-in-process/trace.mcap",
            "plot: */test_spoof.py_test_spoofs_keep_tracking_low/seed-0-in-process/trace.png",
        ]
    )
    directory = (
        pytester.path
        / "artifacts"
        / "test_spoof.py_test_spoofs_keep_tracking_low"
        / "seed-0-in-process"
    )
    assert (directory / "trace.png").read_bytes().startswith(b"\x89PNG")
    trace = read_trace(directory / "trace.mcap")
    expected = {
        "px4/gps",  # what the world measured
        "px4/gps/attacked",  # what the autopilot read
        "px4/truth",
        "px4/location/truth",
        "px4/location/estimate",
        "px4/pose",
        "mcs/trajectory",
        "mcs/robustness",
    }
    assert expected <= set(trace.channels)
    assert trace.channels["px4/location/truth"].schema_name == "foxglove.LocationFix"
    assert trace.channels["px4/pose"].schema_name == "foxglove.PoseInFrame"
    info = trace.info
    assert info["fidelity"] == "low"
    assert info["seed"] == "0"
    assert "spoof=build(5, 0, 3)" in info["failing_example"]
    assert float(info["robustness"]) < 0
    # The trace is the minimal example's: its spoof, seen between the two GPS channels.
    raw = trace.topic("px4/gps")[-1].data
    spoofed = trace.topic("px4/gps/attacked")[-1].data
    assert raw != spoofed
    # The truth track shows where the spoof pulled the vehicle, away from its estimate.
    last_fix = trace.topic("px4/location/truth")[-1].data
    north, east = PROJ.project(last_fix["latitude"], last_fix["longitude"])
    assert math.hypot(north, east - 40.0) > LIMIT - 1.0
