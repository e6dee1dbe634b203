"""ArduPilot regression suite: ArduCopter and ArduRover fly our worlds as configured.

Run with ``pytest scenarios/test_ardupilot.py --mcs-fidelity=medium,high
--mcs-ardupilot-dir=DIR`` (``MCS_ARDUPILOT_DIR``; add ``--mcs-placement=docker`` for
ArduPilot in a container). Without ArduPilot the tests are skipped with the reason. Each
test gets a fresh simulation (stopped at teardown, whatever happens); ArduPilot's estimator
is ready to arm after about 40 simulated seconds, so missions start there.

The GPS-noise case study runs against ArduPilot's EKF3: ``gps_noise`` maps the attack
models onto ArduPilot's own simulated GPS faults.
"""

from __future__ import annotations

import itertools
import math

import pytest

import multicosim.ardupilot as ardupilot
import multicosim.attacks as attacks
import multicosim.rover as rover
from multicosim.core.geo import LocalProjection
from pytest_multicosim.gps_noise import GpsNoise

LEVELS = ("medium", "high")
# Estimation error allowed on top of the acceptance radius: ArduPilot's simulated GPS and
# its EKF3 are a metre off at times.
ESTIMATE_MARGIN = 1.5
# ArduPilot's simulated barometer reads about 4 % high (its board temperature model), and its
# altitude estimate follows it: a target altitude is reached a little lower in truth.
BARO_SCALE = 0.94


def wp(home: ardupilot.Home, north: float, east: float, alt: float) -> ardupilot.Waypoint:
    """A waypoint ``north``/``east`` metres from home, ``alt`` above it."""
    return ardupilot.Waypoint.local(north, east, alt, home)


def true_ne(home: ardupilot.Home, sample: ardupilot.FlightSample) -> tuple[float, float]:
    """The world's true north/east position of ``sample``."""
    return LocalProjection(home.lat, home.lon).project(sample.true_lat, sample.true_lon)


def check_common(
    result: ardupilot.MissionResult, config: ardupilot.Configuration, home: ardupilot.Home
) -> None:
    """What every completed mission must satisfy."""
    assert result.completed, result.reason
    assert result.firmware_version == "4.5.6"
    # Every waypoint reached, in order, within the acceptance radius (truth).
    assert [r.index for r in result.reached] == list(range(len(config.mission)))
    assert [r.time for r in result.reached] == sorted(r.time for r in result.reached)
    proj = LocalProjection(home.lat, home.lon)
    for r in result.reached:
        target = config.mission[r.index]
        tn, te = proj.project(target.lat, target.lon)
        sample = min(result.trajectory, key=lambda s: abs(s.time - r.time))
        n, e = true_ne(home, sample)
        assert math.hypot(n - tn, e - te) <= config.acceptance_radius + ESTIMATE_MARGIN, r
    # Never below the ground (at home altitude here).
    assert min(s.true_alt for s in result.trajectory) > -0.3
    # Sampled at >= 10 Hz throughout.
    times = [s.time for s in result.trajectory]
    assert max(b - a for a, b in itertools.pairwise(times)) <= 0.1 + 1e-6


# -- ArduCopter ---------------------------------------------------------------------------------


@pytest.mark.fidelity(*LEVELS)
def test_copter_mission_lands_at_last_waypoint(
    ardupilot_copter_simulation: ardupilot.ArduPilotSimulation,
) -> None:
    home = ardupilot_copter_simulation.home
    config = ardupilot.Configuration(
        [wp(home, 40, 0, 15), wp(home, 40, 40, 20), wp(home, 0, 40, 15)], end="land"
    )
    result = ardupilot_copter_simulation.firmware.send(config)
    check_common(result, config, home)
    assert result.landed
    assert not result.armed
    last = result.trajectory[-1]
    n, e = true_ne(home, last)
    assert math.hypot(n - 0, e - 40) < config.acceptance_radius + ESTIMATE_MARGIN
    assert abs(last.true_alt) < 0.3
    # Armed in GUIDED, then AUTO for the whole mission (takeoff, waypoints, landing).
    modes = [m for m, _ in itertools.groupby(s.mode for s in result.trajectory if s.armed)]
    assert modes == ["GUIDED", "AUTO"]
    assert max(s.true_alt for s in result.trajectory) > 20.0 * BARO_SCALE


@pytest.mark.fidelity(*LEVELS)
def test_copter_mission_returns_to_launch(
    ardupilot_copter_simulation: ardupilot.ArduPilotSimulation,
) -> None:
    home = ardupilot_copter_simulation.home
    config = ardupilot.Configuration([wp(home, 50, 20, 12)], end="rtl", cruise_speed=8.0)
    result = ardupilot_copter_simulation.firmware.send(config)
    check_common(result, config, home)
    assert result.landed
    assert not result.armed
    n, e = true_ne(home, result.trajectory[-1])
    assert math.hypot(n, e) < 2.0 + ESTIMATE_MARGIN, "did not land at home"
    # ArduCopter returns at RTL_ALT (15 m), above the waypoint's 12 m.
    assert max(s.true_alt for s in result.trajectory) > 15.0 * BARO_SCALE


@pytest.mark.fidelity(*LEVELS)
def test_copter_mission_holds_at_last_waypoint(
    ardupilot_copter_simulation: ardupilot.ArduPilotSimulation,
) -> None:
    home = ardupilot_copter_simulation.home
    config = ardupilot.Configuration([wp(home, -30, 10, 10)], end="hold")
    result = ardupilot_copter_simulation.firmware.send(config)
    check_common(result, config, home)
    assert result.armed
    assert not result.landed
    # It keeps holding there while the simulation runs on.
    ardupilot_copter_simulation.advance(5.0)
    again = ardupilot_copter_simulation.firmware.send(
        ardupilot.Configuration([wp(home, -30, 10, 10)], end="hold", time_limit=60.0)
    )
    assert again.completed, again.reason
    last = again.trajectory[-1]
    n, e = true_ne(home, last)
    assert math.hypot(n + 30, e - 10) < config.acceptance_radius + ESTIMATE_MARGIN
    assert last.true_alt == pytest.approx(10 * BARO_SCALE, abs=ESTIMATE_MARGIN)


@pytest.mark.fidelity(*LEVELS)
def test_copter_time_limit_returns_incomplete(
    ardupilot_copter_simulation: ardupilot.ArduPilotSimulation,
) -> None:
    home = ardupilot_copter_simulation.home
    config = ardupilot.Configuration([wp(home, 300, 0, 20)], time_limit=70.0)
    result = ardupilot_copter_simulation.firmware.send(config)
    assert not result.completed
    assert "time limit" in result.reason
    assert result.duration == pytest.approx(70.0, abs=0.2)


# -- ArduRover ----------------------------------------------------------------------------------


@pytest.mark.fidelity(*LEVELS)
def test_rover_mission_stops_at_last_waypoint(
    ardupilot_rover_simulation: ardupilot.ArduPilotSimulation,
) -> None:
    home = ardupilot_rover_simulation.home
    # A first leg long enough to reach its cruise speed.
    config = ardupilot.Configuration([wp(home, 40, 0, 0), wp(home, 40, 20, 0)], end="land")
    result = ardupilot_rover_simulation.firmware.send(config)
    check_common(result, config, home)
    assert not result.armed  # stopped there and disarmed
    n, e = true_ne(home, result.trajectory[-1])
    assert math.hypot(n - 40, e - 20) < config.acceptance_radius + ESTIMATE_MARGIN
    assert "AUTO" in {s.mode for s in result.trajectory}
    # It drove at about its cruise speed (5 m/s) on the way.
    assert max(math.hypot(s.vx, s.vy) for s in result.trajectory) == pytest.approx(5.0, abs=1.0)


@pytest.mark.fidelity(*LEVELS)
def test_rover_mission_returns_to_launch(
    ardupilot_rover_simulation: ardupilot.ArduPilotSimulation,
) -> None:
    home = ardupilot_rover_simulation.home
    config = ardupilot.Configuration([wp(home, 25, -10, 0)], end="rtl")
    result = ardupilot_rover_simulation.firmware.send(config)
    check_common(result, config, home)
    assert not result.armed
    n, e = true_ne(home, result.trajectory[-1])
    # ArduRover ends RTL once home is within its radius or it has crossed the line through
    # home square to its track (AR_WPNav's overshoot test): a car that cannot turn onto home
    # crosses that line beside it, up to its turning radius off.
    turning_radius = rover.WHEELBASE / math.tan(rover.MAX_STEERING)
    limit = config.acceptance_radius + turning_radius + ESTIMATE_MARGIN
    assert math.hypot(n, e) < limit, "did not stop at home"


# -- the GPS-noise case study on ArduPilot's EKF3 --------------------------------------------


@pytest.mark.fidelity(*LEVELS)
def test_copter_completes_under_small_gps_noise(
    ardupilot_copter_simulator: ardupilot.ArduCopter, gps_noise: GpsNoise
) -> None:
    gps_noise(std=0.5, drift=0.05)
    simulation = ardupilot_copter_simulator.start()
    home = simulation.home
    config = ardupilot.Configuration([wp(home, 20, 0, 10), wp(home, 20, 20, 12)], end="land")
    result = simulation.firmware.send(config)
    check_common(result, config, home)
    n, e = true_ne(home, result.trajectory[-1])
    assert math.hypot(n - 20, e - 20) < config.acceptance_radius + ESTIMATE_MARGIN


@pytest.mark.fidelity(*LEVELS)
def test_copter_gps_spoof_pulls_the_vehicle_by_its_offset(
    ardupilot_copter_simulator: ardupilot.ArduCopter, gps_noise: GpsNoise
) -> None:
    # From t = 90 s, when it holds at the waypoint: 10 m north, ramped over 2 s.
    gps_noise(spoof=attacks.Local(north=10.0), start=90.0, ramp=2.0)
    simulation = ardupilot_copter_simulator.start()
    home = simulation.home
    config = ardupilot.Configuration([wp(home, 0, 40, 10)], end="hold", acceptance_radius=1.0)
    first = simulation.firmware.send(config)
    assert first.completed, first.reason
    assert first.end_time < 90.0
    simulation.advance(110.0 - simulation.time)
    result = simulation.firmware.send(config)
    assert result.completed, result.reason
    last = result.trajectory[-1]
    proj = LocalProjection(home.lat, home.lon)
    est_n, est_e = proj.project(last.lat, last.lon)
    true_n, true_e = true_ne(home, last)
    # ArduCopter believes it holds at the waypoint; in truth it is 10 m south of it.
    assert math.hypot(est_n, est_e - 40) < 1.5
    assert true_n - est_n == pytest.approx(-10.0, abs=1.0)
    assert true_e - est_e == pytest.approx(0.0, abs=1.0)


@pytest.mark.fidelity(*LEVELS)
def test_copter_gps_dropout_triggers_the_ekf_failsafe(
    ardupilot_copter_simulator: ardupilot.ArduCopter, gps_noise: GpsNoise
) -> None:
    gps_noise(dropout=True, start=70.0, end=100.0)
    simulation = ardupilot_copter_simulator.start()
    home = simulation.home
    result = simulation.firmware.send(
        ardupilot.Configuration([wp(home, 120, 0, 15)], time_limit=200.0)
    )
    assert not result.completed
    assert "EKF Failsafe: changed to LAND Mode" in result.messages
    failsafe = next(s for s in result.trajectory if s.mode == "LAND")
    # EKF3 gives up on its position a few seconds into the loss (its variance check).
    assert 70.0 < failsafe.time < 80.0
    assert result.landed
    assert not result.armed
    assert min(s.true_alt for s in result.trajectory) > -0.3
