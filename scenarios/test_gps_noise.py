"""Regression suite of the GPS-noise scenario (the paper's third case study).

A sensor injector sits between the world and the firmware (``gps_noise`` fixture) and
corrupts the GPS or the compass; the firmware cannot tell except through its data::

    pytest scenarios/test_gps_noise.py --mcs-fidelity=low,medium

Assertions are on simulated quantities only: true and estimated positions, headings,
failsafe outcomes, and the messages themselves (identical runs are compared exactly).
"""

from __future__ import annotations

import math
from typing import Any

import pytest

import multicosim as mcs
import multicosim.attacks as attacks
import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim.core.geo import LocalProjection
from multicosim.rover import SENSOR_TOPICS, Mission, Position
from pytest_multicosim.gps_noise import GpsNoise

LEVELS = ("low", "medium")
HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)

ROVER_MISSION = Mission(speed=3.0, wait=1.0, distance=5.0, final_distance=5.0)


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


class Probe:
    """Records every message of a topic with its publication time (in this process)."""

    def __init__(self, topic: str, tp: type[Any], period: float) -> None:
        self.topic, self.type, self.period = topic, tp, period
        self.messages: list[tuple[float, Any]] = []

    def setup(self, ctx: mcs.StepContext) -> None:
        self.sub = ctx.subscribe(self.topic, self.type)

    def step(self, ctx: mcs.StepContext) -> None:
        self.messages.extend((ctx.time, m) for m in self.sub.messages)


def probe(simulator: Any, topic: str, tp: type[Any], period: float, name: str = "probe") -> Probe:
    """Add a probe on ``topic`` to ``simulator`` (after any injector, before the firmware)."""
    recorder = Probe(topic, tp, period)
    simulator.add(mcs.InProcessComponent(lambda: recorder, name=name))
    return recorder


# -- PX4 ------------------------------------------------------------------------------------


@pytest.mark.fidelity(*LEVELS)
def test_px4_mission_completes_within_tolerance_under_small_noise(
    px4_simulator: px4.PX4, gps_noise: GpsNoise
) -> None:
    gps_noise(std=0.5, drift=0.05)
    config = px4.Configuration([wp(20, 0, 10), wp(20, 20, 12)], end="land")
    result = px4_simulator.start().firmware.send(config)
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0, 1]
    last = result.trajectory[-1]
    north, east = PROJ.project(last.true_lat, last.true_lon)
    # Landed at the last waypoint within the acceptance radius plus the noise's share.
    assert math.hypot(north - 20, east - 20) < config.acceptance_radius + 1.5
    assert min(s.true_alt for s in result.trajectory) > -0.3


@pytest.mark.fidelity(*LEVELS)
def test_px4_gps_spoof_pulls_the_vehicle_by_its_offset(
    px4_simulator: px4.PX4, gps_noise: GpsNoise
) -> None:
    gps_noise(spoof=attacks.Local(north=10.0), start=8.0, ramp=2.0)  # 10 m north, ramped
    result = px4_simulator.start().firmware.send(
        px4.Configuration([wp(0, 40, 10)], end="hold", acceptance_radius=1.0)
    )
    assert result.completed, result.reason
    last = result.trajectory[-1]
    est_n, est_e = PROJ.project(last.lat, last.lon)
    true_n, true_e = PROJ.project(last.true_lat, last.true_lon)
    # The autopilot believes it holds at the waypoint; in truth it is 10 m south of it (give
    # or take the receiver's own drifting error).
    assert math.hypot(est_n, est_e - 40) < 1.5
    assert true_n - est_n == pytest.approx(-10.0, abs=1.0)
    assert true_e - est_e == pytest.approx(0.0, abs=1.0)


@pytest.mark.fidelity(*LEVELS)
def test_px4_gps_dropout_triggers_the_failsafe(px4_simulator: px4.PX4, gps_noise: GpsNoise) -> None:
    gps_noise(dropout=True, start=12.0, end=40.0)
    result = px4_simulator.start().firmware.send(
        px4.Configuration([wp(100, 0, 15)], time_limit=120.0)
    )
    assert not result.completed
    assert "Failsafe" in result.reason, result.reason
    failsafe = next(s for s in result.trajectory if s.mode == "AUTO.LAND")
    # PX4 dead-reckons for up to EKF2_NOAID_TOUT (5 s), then fails over (real PX4 a second
    # later when it loses GPS climbing, as here, than in a mission leg).
    assert 16.5 < failsafe.time < 18.5
    assert result.landed
    assert not result.armed
    assert min(s.true_alt for s in result.trajectory) > -0.3
    # Blind, PX4 descends (Descend) at MPC_LAND_SPEED (0.7 m/s) all the way, not at
    # MPC_Z_V_AUTO_DN (1.5 m/s) as it lands with a position.
    high = [s for s in result.trajectory if s.time > failsafe.time + 2.0 and s.true_alt > 2.0]
    rate = (high[0].true_alt - high[-1].true_alt) / (high[-1].time - high[0].time)
    assert rate == pytest.approx(0.7, abs=0.15)


# -- the rover ------------------------------------------------------------------------------


@pytest.mark.fidelity(*LEVELS)
def test_rover_gps_spoof_pulls_the_rover_off_its_path(
    rover_simulator: rover.Rover, gps_noise: GpsNoise
) -> None:
    # 2 m ahead (east, the first leg's direction) from t = 2 s, during the first leg.
    injector = gps_noise(spoof=attacks.Local(east=2.0), start=2.0)
    assert isinstance(injector.config, attacks.InjectorConfig)  # the rover's is an injector
    truth = probe(rover_simulator, injector.config.source, Position, 0.025)
    trajectory = rover_simulator.start().controller.send(ROVER_MISSION)
    assert trajectory.completed, trajectory.reason
    end = trajectory.final
    true_end = truth.messages[-1][1]
    plan_x, plan_y, _ = rover.planned_endpoint(ROVER_MISSION)
    # The controller believes it ended on plan; the first leg was in truth 2 m short.
    assert math.hypot(end.x - plan_x, end.y - plan_y) < 1.0
    assert true_end.x - end.x == pytest.approx(-2.0, abs=0.1)
    assert true_end.y - end.y == pytest.approx(0.0, abs=0.1)
    assert math.hypot(true_end.x - plan_x, true_end.y - plan_y) > 1.5


@pytest.mark.fidelity(*LEVELS)
def test_rover_heading_attack_changes_its_turn(
    rover_simulator: rover.Rover, gps_noise: GpsNoise
) -> None:
    # During the turn (about 3.2 s to 4.1 s) the compass jumps 20 degrees further left.
    injector = gps_noise(sensor="magnetometer", spoof=math.radians(20.0), start=3.5)
    assert isinstance(injector.config, attacks.InjectorConfig)  # the rover's is an injector
    truth = probe(rover_simulator, injector.config.source, rover.MagneticField, 0.025)
    trajectory = rover_simulator.start().controller.send(ROVER_MISSION)
    assert trajectory.completed, trajectory.reason
    believed = trajectory.final.heading
    field = truth.messages[-1][1]
    true_heading = rover.heading_from_field(field.x, field.y)
    _, _, planned = rover.planned_endpoint(ROVER_MISSION)
    # It believes it turned the planned 70 degrees; it really turned about 20 fewer.
    assert abs(math.remainder(believed - planned, math.tau)) < math.radians(8.0)
    assert math.degrees(math.remainder(believed - true_heading, math.tau)) == pytest.approx(
        20.0, abs=1.0
    )


# -- exactness ------------------------------------------------------------------------------


def _rover_run(
    fidelity: str, seed: int, models: list[attacks.Model] | None
) -> tuple[rover.Trajectory, list[tuple[float, Position]], list[tuple[float, Position]]]:
    """The trajectory, the positions the controller read and those the world published."""
    simulator = rover.Rover(fidelity=fidelity, seed=seed)  # type: ignore[arg-type]
    raw = SENSOR_TOPICS["position"]
    if models is not None:
        raw = attacks.inject(simulator, "gps", models).config.source
    world = probe(simulator, raw, Position, 0.025, "world-probe")
    sensed = probe(simulator, SENSOR_TOPICS["position"], Position, 0.025, "sensed-probe")
    with simulator.start() as simulation:
        trajectory = simulation.controller.send(ROVER_MISSION)
    return trajectory, sensed.messages, world.messages


ZERO: list[attacks.Model] = [
    attacks.Gaussian(std=0.0),
    attacks.Bias(offset=attacks.Local()),
    attacks.Drift(std=0.0),
    attacks.Jump(offset=0.0, start=2.0, ramp=1.0),
    attacks.Delay(delay=0.0),
]


@pytest.mark.fidelity(*LEVELS)
def test_rover_run_with_a_zero_injector_is_identical(mcs_fidelity: str, mcs_seed: int) -> None:
    plain = _rover_run(mcs_fidelity, mcs_seed, None)
    zero = _rover_run(mcs_fidelity, mcs_seed, ZERO)
    assert zero[:2] == plain[:2]  # what the controller read, and what it did
    assert zero[1] == zero[2]  # the injector passed every reading on, in the same instant


@pytest.mark.fidelity(*LEVELS)
def test_px4_run_with_a_zero_injector_is_identical(mcs_fidelity: str, mcs_seed: int) -> None:
    config = px4.Configuration([wp(0, 15, 8)], end="hold")
    results = []
    for models in (None, ZERO):
        simulator = px4.PX4(fidelity=mcs_fidelity, seed=mcs_seed)  # type: ignore[arg-type]
        if models is not None:
            attacks.inject(simulator, "gps", models)
        with simulator.start() as simulation:
            results.append(simulation.firmware.send(config))
    assert results[0] == results[1]
    assert results[0].completed


@pytest.mark.fidelity(*LEVELS)
def test_same_seed_gives_the_same_corrupted_trace(mcs_fidelity: str, mcs_seed: int) -> None:
    noisy: list[attacks.Model] = [
        attacks.Gaussian(std=0.3),
        attacks.Drift(std=0.2, start=1.0),
        attacks.Delay(delay=0.05, start=3.0, end=4.0),
    ]
    first = _rover_run(mcs_fidelity, mcs_seed, noisy)
    again = _rover_run(mcs_fidelity, mcs_seed, noisy)
    other = _rover_run(mcs_fidelity, mcs_seed + 1, noisy)
    assert first == again
    assert first[1] != other[1]
    # The readings really were corrupted: a few decimetres off what the world published.
    errors = [
        math.hypot(a.x - b.x, a.y - b.y)
        for (_, a), (_, b) in zip(first[1][:40], first[2][:40], strict=True)
    ]
    assert 0.1 < sum(errors) / len(errors) < 1.0
