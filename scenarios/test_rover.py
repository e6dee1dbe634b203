"""Regression suite of the rover FSA scenario (the paper's second case study).

Runs at every fidelity level it is marked for and selected with ``--mcs-fidelity``, on the
placement ``--mcs-placement`` selects::

    pytest scenarios/test_rover.py --mcs-fidelity=low,medium
    pytest scenarios/test_rover.py --mcs-fidelity=high --mcs-placement=docker

Assertions are on simulated quantities only (positions, headings, speeds, simulated time).
"""

from __future__ import annotations

import itertools
import math

import pytest

import multicosim.rover as rover
from multicosim.rover import Mission, RoverSimulation, Trajectory, planned_endpoint
from pytest_multicosim import Simulations

ALL_LEVELS = ("low", "medium", "high")

# Short missions keep the suite fast; the defaults (70 degrees, 0.5 rad) follow the reference.
MISSION = Mission(speed=3.0, wait=1.0, distance=5.0, final_distance=5.0)

# How far the rover may end from the planned end point (m) and how far its turn may differ
# from the planned angle, per fidelity: physics adds tyre slip and steering servo lag, and
# noise makes the controller decide on slightly wrong readings.
END_TOLERANCE = {"low": 0.5, "medium": 1.5, "high": 1.5}
TURN_TOLERANCE = {
    "low": math.radians(6.0),
    "medium": math.radians(12.0),
    "high": math.radians(12.0),
}


def _segment(trajectory: Trajectory, state: str) -> list[rover.SensedSample]:
    return [s for s in trajectory if s.state == state]


def _ground_speeds(trajectory: Trajectory, window: float = 0.5) -> list[float]:
    """Speeds from positions over ``window`` s, smoothing position noise out."""
    samples = trajectory.samples
    step = max(1, round(window / (samples[1].time - samples[0].time)))
    return [
        math.hypot(b.x - a.x, b.y - a.y) / (b.time - a.time)
        for a, b in zip(samples, samples[step:], strict=False)
    ]


@pytest.mark.fidelity(*ALL_LEVELS)
def test_mission_completes_at_the_planned_end_point(
    rover_simulation: RoverSimulation, mcs_fidelity: str
) -> None:
    trajectory = rover_simulation.controller.send(MISSION)
    assert trajectory.completed, trajectory.reason
    assert trajectory.final_state == "done"
    assert trajectory.states() == ["wait", "drive", "turn", "drive_again", "done"]
    x, y, heading = planned_endpoint(MISSION)
    end = trajectory.final
    assert math.hypot(end.x - x, end.y - y) < END_TOLERANCE[mcs_fidelity]
    assert abs(math.remainder(end.heading - heading, math.tau)) < TURN_TOLERANCE[mcs_fidelity]
    assert abs(end.speed) < 0.05  # at rest in the terminal state
    assert max(abs(s.roll) for s in trajectory) < 0.2  # upright all along
    # Sampled at >= 10 Hz from start to end.
    gaps = [b - a for a, b in itertools.pairwise(trajectory.times)]
    assert max(gaps) <= 0.1 + 1e-9


@pytest.mark.fidelity(*ALL_LEVELS)
@pytest.mark.parametrize("degrees", [45.0, -90.0])
def test_turn_angle_is_respected(
    rover_simulation: RoverSimulation, mcs_fidelity: str, degrees: float
) -> None:
    mission = Mission(
        speed=2.0, wait=0.0, distance=2.0, turn_angle=math.radians(degrees), final_distance=2.0
    )
    trajectory = rover_simulation.controller.send(mission)
    assert trajectory.completed, trajectory.reason
    turn = _segment(trajectory, "turn")
    after = _segment(trajectory, "drive_again")
    turned = math.remainder(after[-1].heading - turn[0].heading, math.tau)
    assert turned == pytest.approx(mission.turn_angle, abs=TURN_TOLERANCE[mcs_fidelity])
    # The turn went the asked way all along (no overshoot back and forth).
    sign = math.copysign(1.0, degrees)
    headings = [s.heading for s in turn]
    progress = [sign * math.remainder(b - a, math.tau) for a, b in itertools.pairwise(headings)]
    assert min(progress) > -0.02


@pytest.mark.fidelity(*ALL_LEVELS)
def test_speed_limits_hold(rover_simulation: RoverSimulation) -> None:
    mission = Mission(speed=2.5, turn_speed=1.5, wait=0.5, distance=5.0, final_distance=5.0)
    trajectory = rover_simulation.controller.send(mission)
    assert trajectory.completed, trajectory.reason
    limit = mission.speed * 1.05 + 0.05
    assert max(s.speed for s in trajectory) <= limit  # wheel odometry
    assert max(_ground_speeds(trajectory)) <= limit  # what the position fixes say
    turn = _segment(trajectory, "turn")
    assert max(s.speed for s in turn[len(turn) // 2 :]) <= mission.cruise_turn_speed * 1.05 + 0.05
    waiting = _segment(trajectory, "wait")
    assert max(abs(s.speed) for s in waiting) < 0.05
    # The rover gets up to speed on the first leg.
    assert max(s.speed for s in _segment(trajectory, "drive")) > 0.9 * mission.speed


@pytest.mark.fidelity(*ALL_LEVELS)
@pytest.mark.parametrize("abort_at", [0.0, 2.0, 3.5])
def test_abort_stops_the_rover(rover_simulation: RoverSimulation, abort_at: float) -> None:
    trajectory = rover_simulation.controller.send(
        Mission(speed=3.0, wait=0.5, distance=3.0, final_distance=5.0, abort_at=abort_at)
    )
    assert trajectory.final_state == "aborted"
    assert not trajectory.completed
    aborted = _segment(trajectory, "aborted")
    assert aborted[0].time - trajectory.start_time == pytest.approx(abort_at, abs=1e-6)
    first = aborted[0]
    end = trajectory.final
    assert abs(end.speed) < 0.05
    # It stops within the braking distance from the speed it had (plus margin for noise).
    braking = first.speed**2 / (2 * rover.ACCELERATION * 0.8) + 0.3
    assert math.hypot(end.x - first.x, end.y - first.y) <= braking


@pytest.mark.fidelity(*ALL_LEVELS)
def test_same_seed_same_trajectory(
    rover_simulator: rover.Rover, mcs_simulations: Simulations
) -> None:
    """Determinism: the same seed reproduces the trajectory bit for bit."""
    mission = Mission(speed=3.0, wait=0.2, distance=3.0, final_distance=3.0)
    again = rover.Rover(
        fidelity=rover_simulator.fidelity,
        placement=rover_simulator.placement,
        seed=rover_simulator.seed,
        world=rover_simulator.config.world,
        noise=rover_simulator.config.noise,
    )
    first = rover_simulator.start()
    runs = [first.controller.send(mission)]
    first.stop()
    second = mcs_simulations.start(again)
    runs.append(second.controller.send(mission))
    assert runs[0].completed, runs[0].reason
    assert runs[0] == runs[1]
