"""PX4 regression suite: missions fly as configured at every fidelity marked.

Run with ``pytest scenarios/test_px4.py --mcs-fidelity=low,medium`` (add
``--mcs-fidelity=high --mcs-placement=docker`` for containers). Each test gets a fresh
simulation from the ``px4_simulation`` fixture (stopped at teardown, whatever happens).
"""

from __future__ import annotations

import itertools
import math

import pytest

import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from pytest_multicosim import Simulations

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
# Estimation error allowed on top of the acceptance radius (GPS noise at medium fidelity:
# a receiver's error drifts by about 0.3 m horizontally and 0.5 m vertically, one sigma).
ESTIMATE_MARGIN = 1.5
ALL_LEVELS = ("low", "medium", "high")


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


def true_ne(sample: px4.FlightSample) -> tuple[float, float]:
    """The world's true north/east position of ``sample``."""
    return PROJ.project(sample.true_lat, sample.true_lon)


def sample_at(result: px4.MissionResult, time: float) -> px4.FlightSample:
    """The trajectory sample closest to simulated ``time``."""
    return min(result.trajectory, key=lambda s: abs(s.time - time))


def check_common(result: px4.MissionResult, config: px4.Configuration) -> None:
    """What every completed mission must satisfy."""
    assert result.completed, result.reason
    # Every waypoint reached, in order, within the acceptance radius (truth).
    assert [r.index for r in result.reached] == list(range(len(config.mission)))
    assert [r.time for r in result.reached] == sorted(r.time for r in result.reached)
    for r in result.reached:
        target = config.mission[r.index]
        tn, te = PROJ.project(target.lat, target.lon)
        n, e = true_ne(sample_at(result, r.time))
        dist = math.hypot(n - tn, e - te)
        assert dist <= config.acceptance_radius + ESTIMATE_MARGIN, (r, dist)
    # Never below the ground (the ground is at home altitude here).
    assert min(s.true_alt for s in result.trajectory) > -0.3
    # Sampled at >= 10 Hz throughout.
    times = [s.time for s in result.trajectory]
    assert max(b - a for a, b in itertools.pairwise(times)) <= 0.1 + 1e-6


@pytest.mark.fidelity(*ALL_LEVELS)
def test_mission_lands_at_last_waypoint(px4_simulation: px4.PX4Simulation) -> None:
    config = px4.Configuration([wp(40, 0, 15), wp(40, 40, 20), wp(0, 40, 15)], end="land")
    result = px4_simulation.firmware.send(config)
    check_common(result, config)
    assert result.landed
    assert not result.armed
    last = result.trajectory[-1]
    n, e = true_ne(last)
    assert math.hypot(n - 0, e - 40) < config.acceptance_radius + ESTIMATE_MARGIN
    assert abs(last.true_alt) < 0.3
    # The flight went through the takeoff, mission and landing the configuration asks for.
    modes = {s.mode for s in result.trajectory if s.armed}
    assert "AUTO.MISSION" in modes
    assert max(s.true_alt for s in result.trajectory) > 18.0


@pytest.mark.fidelity(*ALL_LEVELS)
def test_mission_returns_to_launch(px4_simulation: px4.PX4Simulation) -> None:
    config = px4.Configuration([wp(50, 20, 12)], end="rtl", cruise_speed=8.0)
    result = px4_simulation.firmware.send(config)
    check_common(result, config)
    assert result.landed
    assert not result.armed
    n, e = true_ne(result.trajectory[-1])
    assert math.hypot(n, e) < 2.0 + ESTIMATE_MARGIN, "did not land at home"
    # RTL climbs to RTL_RETURN_ALT (30 m) before returning.
    assert max(s.true_alt for s in result.trajectory) > 28.0


@pytest.mark.fidelity(*ALL_LEVELS)
def test_mission_holds_at_last_waypoint(px4_simulation: px4.PX4Simulation) -> None:
    config = px4.Configuration([wp(-30, 10, 10)], end="hold")
    result = px4_simulation.firmware.send(config)
    check_common(result, config)
    assert result.armed
    assert not result.landed
    # It keeps holding there while the simulation runs on.
    px4_simulation.advance(5.0)
    again = px4_simulation.firmware.send(
        px4.Configuration([wp(-30, 10, 10)], end="hold", time_limit=60.0)
    )
    assert again.completed, again.reason
    last = again.trajectory[-1]
    n, e = true_ne(last)
    assert math.hypot(n + 30, e - 10) < config.acceptance_radius + ESTIMATE_MARGIN
    assert abs(last.true_alt - 10) < ESTIMATE_MARGIN


@pytest.mark.fidelity(*ALL_LEVELS)
def test_time_limit_returns_incomplete(px4_simulation: px4.PX4Simulation) -> None:
    config = px4.Configuration([wp(300, 0, 20)], time_limit=15.0)
    result = px4_simulation.firmware.send(config)
    assert not result.completed
    assert "time limit" in result.reason
    assert result.end_time - result.start_time == pytest.approx(15.0, abs=0.2)


@pytest.mark.fidelity(*ALL_LEVELS)
def test_same_seed_gives_the_same_trajectory(
    px4_simulator: px4.PX4,
    mcs_seed: int,
    px4_params: dict[str, float],
    mcs_simulations: Simulations,
) -> None:
    config = px4.Configuration([wp(20, 10, 8)], end="hold", time_limit=40.0)
    again = px4.PX4(
        px4_simulator.world,
        fidelity=px4_simulator.fidelity,
        placement=px4_simulator.placement,
        seed=mcs_seed,
        params=px4_params,
        firmware=px4_simulator.firmware,
    )
    first = px4_simulator.start()
    results = [first.firmware.send(config)]
    first.stop()
    second = mcs_simulations.start(again)
    results.append(second.firmware.send(config))
    assert results[0].completed, results[0].reason
    if px4_simulator.firmware is None:
        assert results[0] == results[1]
        return
    # Real PX4 runs its modules as threads: its lockstep clock is ours, but which thread
    # answers first is not, so a replay is close, not bit-for-bit.
    # One may also take off a moment later than the other (a mission upload that needed a
    # retransmission over UDP): compare how long each flew from arming, and where.
    a, b = results
    assert [r.index for r in a.reached] == [r.index for r in b.reached]

    def flight_time(r: px4.MissionResult) -> float:
        return r.end_time - next(s.time for s in r.trajectory if s.armed)

    assert flight_time(a) == pytest.approx(flight_time(b), abs=2.0)
    gap = max(a.path_gap(b)[1], b.path_gap(a)[1])
    assert gap < 1.0, f"replays with seed {mcs_seed} parted by {gap:.2f} m"
