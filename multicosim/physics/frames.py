"""From MuJoCo's frames to the autopilots': one conversion for every vehicle.

MuJoCo's world frame is east-north-up and a body's frame forward-left-up; autopilots (PX4,
ArduPilot) use north-east-down and forward-right-down. ``ned_state`` turns a body's
MuJoCo state into the autopilots' true state once per period (``multicosim.mavlink.hil.truth``
wraps it as the message an external autopilot's simulator interface reads). Scalar math
only: this runs every physics period.
"""

from __future__ import annotations

from typing import NamedTuple

from ..core.geo import Quaternion, swap_attitude_frames

__all__ = ["NedState", "Vec3", "ned_state"]

Vec3 = tuple[float, float, float]


class NedState(NamedTuple):
    """A body's true state in the autopilots' frames.

    ``ned``: position (m) from home, down measured from the ground contact (0 standing);
    ``vel``: velocity (m/s, NED); ``q``: attitude (w, x, y, z, FRD body to NED); ``accel``:
    specific force (m/s^2, FRD: gravity included, ``(0, 0, -g)`` at rest); ``gyro``: angular
    rate (rad/s, FRD).
    """

    ned: Vec3
    vel: Vec3
    q: Quaternion
    accel: Vec3
    gyro: Vec3


def ned_state(
    pos: tuple[float, ...],
    vel: tuple[float, ...],
    q: tuple[float, ...],
    accel: tuple[float, ...],
    gyro: tuple[float, ...],
    height: float,
) -> NedState:
    """The state of a body from MuJoCo's readings of it (ENU world, FLU body).

    ``pos``/``vel``: the reference point's position and velocity (ENU); ``q``: its attitude
    (FLU to ENU); ``accel``/``gyro``: its accelerometer and gyro (FLU); ``height``: the
    reference point's height above the ground when the vehicle stands (down is 0 there).
    """
    x, y, z = pos[0], pos[1], pos[2]
    return NedState(
        (y, x, height - z),
        (vel[1], vel[0], -vel[2]),
        swap_attitude_frames(q),
        (accel[0], -accel[1], -accel[2]),
        (gyro[0], -gyro[1], -gyro[2]),
    )
