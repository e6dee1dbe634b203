"""The built-in autopilot's estimator on its own: sensor faults it must shrug off."""

from __future__ import annotations

import math
import random

from multicosim.core.geo import GRAVITY, LocalProjection
from multicosim.px4.autopilot.estimator import Estimator
from multicosim.px4.autopilot.firmware import Autopilot


def _field(yaw: float) -> tuple[float, float, float]:
    # The earth's field (north and down) seen by a level vehicle heading ``yaw``, body FRD.
    return (0.2 * math.cos(yaw), -0.2 * math.sin(yaw), 0.4)


def test_a_frozen_compass_leaves_the_heading_to_the_gyro() -> None:
    est = Estimator()
    rate, now = 250, 0.0
    for k in range(10 * rate):
        now = k / rate
        # A still, level vehicle with a noisy gyro (a real one never reads exactly zero).
        gyro = (1e-4 * (-1) ** k, -1e-4 * (-1) ** k, 1e-4 * (-1) ** (k // 2))
        est.imu(now, 1 / rate, (0.0, 0.0, -GRAVITY), gyro)
        if k % 5 == 0:
            # Heading 0 for a second, then the compass freezes on a reading 0.3 rad off.
            est.mag(now, _field(0.0) if now < 1.0 else _field(0.3))
    heading = est.euler()[2]
    # The frozen reading is dropped within a quarter of a second and nothing keeps turning
    # the heading after it: it stays near where it was.
    assert abs(heading) < 0.1, heading


def test_a_silent_compass_leaves_the_heading_to_the_gyro() -> None:
    est = Estimator()
    rate, now = 250, 0.0
    for k in range(10 * rate):
        now = k / rate
        est.imu(now, 1 / rate, (0.0, 0.0, -GRAVITY), (0.0, 0.0, 0.0))
        if k % 5 == 0 and now < 1.1:
            # Heading 0 for a second, a tenth of a second 0.3 rad off, then no compass at all.
            est.mag(now, _field(0.0) if now < 1.0 else _field(0.3))
    # The last correction lapses with its sensor: the heading does not keep turning.
    assert abs(est.euler()[2]) < 0.1, est.euler()[2]


def test_losing_gps_in_a_banked_turn_keeps_the_tilt_the_gyros_give() -> None:
    # A drag-free multirotor banked 10 degrees, accelerating east: its accelerometer reads
    # only the thrust along its body axis, as if it were level under a stronger gravity.
    roll = math.radians(10.0)
    c, s = math.cos(roll), math.sin(roll)
    accel = GRAVITY * math.tan(roll)
    origin = LocalProjection(47.0, 8.0)
    est = Estimator()
    est.in_air = True
    rate = 250
    for k in range(20 * rate):
        now = k / rate
        est.imu(now, 1 / rate, (0.0, 0.0, -GRAVITY / c), (0.0, 0.0, 0.0))
        if k % 5 == 0:
            est.mag(now, (0.2, s * 0.4, c * 0.4))  # the field (north, down) seen banked
        # 10 Hz GPS for 10 s (its tilt correction is slow: a time constant of 2 s), then none.
        if k % 25 == 0 and now < 10.0:
            lat, lon = origin.reproject(0.0, 0.5 * accel * now * now)
            est.gps(
                now, round(lat * 1e7), round(lon * 1e7), 0, (0, round(accel * now * 100), 0), 3, 10
            )
        if k == 10 * rate - 1:
            assert abs(est.euler()[0] - roll) < math.radians(1.0), est.euler()
    # Ten seconds without GPS: the estimate still knows the vehicle banks (taken for gravity,
    # the accelerometer would have levelled it and the controller would fly on tilted).
    assert abs(est.euler()[0] - roll) < math.radians(1.0), est.euler()


def test_gps_velocity_noise_barely_tilts_a_hovering_estimate() -> None:
    # A level hover under 10 Hz GPS whose velocity is noisy (5 cm/s, as the medium world's
    # receiver): each fix's delta-v says "tilted" by about 4 degrees, and a tilt correction
    # that follows every fix shakes the attitude the controller then flies.
    origin = LocalProjection(47.0, 8.0)
    lat, lon = origin.reproject(0.0, 0.0)
    est = Estimator()
    est.in_air = True
    rng = random.Random(1)
    rate, worst = 250, 0.0
    for k in range(30 * rate):
        now = k / rate
        est.imu(now, 1 / rate, (0.0, 0.0, -GRAVITY), (0.0, 0.0, 0.0))
        if k % 5 == 0:
            est.mag(now, _field(0.0))
        if k % 25 == 0:
            vel = (
                round(rng.gauss(0.0, 5.0)),
                round(rng.gauss(0.0, 5.0)),
                round(rng.gauss(0.0, 5.0)),
            )
            est.gps(now, round(lat * 1e7), round(lon * 1e7), 0, vel, 3, 10)
        if now > 5.0:
            roll, pitch, _ = est.euler()
            worst = max(worst, abs(roll), abs(pitch))
    assert worst < math.radians(1.0), math.degrees(worst)


def test_in_flight_the_imu_carries_the_position_for_ekf2_noaid_tout() -> None:
    origin = LocalProjection(47.0, 8.0)
    lat, lon = origin.reproject(0.0, 0.0)

    def fly(in_air: bool) -> list[bool]:
        est = Estimator()
        est.in_air = in_air  # EKF2_NOAID_TOUT is PX4's 5 s
        rate = 250
        seen = []
        for k in range(10 * rate):
            now = k / rate
            est.imu(now, 1 / rate, (0.0, 0.0, -GRAVITY), (0.0, 0.0, 0.0))
            if k % 5 == 0:
                est.mag(now, _field(0.0))
            if k % 25 == 0 and now < 3.0:  # 3 s of GPS (settled after 2), then none
                est.gps(now, round(lat * 1e7), round(lon * 1e7), 0, (0, 0, 0), 3, 10)
            if k % rate == 0:
                seen.append(est.position_ok(now))
        return seen

    # Settled 2 s after the first fix; the last fix at 2.9 s carries the position to 7.9 s in
    # the air, and on the ground only while GPS is fresh (to 3.4 s).
    assert fly(True) == [False, False, True, True, True, True, True, True, False, False]
    assert fly(False) == [False, False, True, True, False, False, False, False, False, False]


def _lying(roll_deg: float) -> Autopilot:
    """An autopilot whose vehicle has lain still for 2 s rolled by ``roll_deg``."""
    ap = Autopilot()
    roll = math.radians(roll_deg)
    rate = 250
    for k in range(2 * rate):
        now = k / rate
        # At rest the accelerometer reads the reaction to gravity, in the tilted body frame.
        ap.est.imu(
            now,
            1 / rate,
            (0.0, -GRAVITY * math.sin(roll), -GRAVITY * math.cos(roll)),
            (0.0, 0.0, 0.0),
        )
        if k % 5 == 0:
            ap.est.mag(now, _field(0.0))
            ap.est.baro(now, 0.0)
        ap._now = now
    return ap


def test_a_vehicle_lying_tipped_over_is_refused_arming_as_by_px4s_failure_detector() -> None:
    assert _lying(70.0).arm_check() == "Preflight Fail: Attitude failure (roll)"
    assert _lying(70.0).arm() is not None
    # On a slope it may take off from, what is left to wait for is a GPS fix, not its attitude.
    assert _lying(5.0).arm_check() == "Preflight Fail: GPS fix too low"
