"""The built-in autopilot's estimator on its own: sensor faults it must shrug off."""

from __future__ import annotations

import math

from multicosim.geo import GRAVITY
from multicosim.px4._estimator import Estimator


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
