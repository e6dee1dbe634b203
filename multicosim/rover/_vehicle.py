"""The rover as a vehicle: geometry, steering geometry, sensor conventions, world configuration.

Shared by the kinematic world (low fidelity) and the MuJoCo world (medium and high), so the
controller cannot tell which one it drives.
"""

from __future__ import annotations

import dataclasses
import math

from ..core.errors import ConfigurationError
from ..physics.config import WorldConfig, check_sensor_topics
from ._messages import SENSOR_TOPICS

__all__ = [
    "ACCELERATION",
    "AXLE_HEIGHT",
    "REACH",
    "TRACK",
    "WHEELBASE",
    "WHEEL_RADIUS",
    "WHEEL_WIDTH",
    "RoverWorldConfig",
    "SensorNoise",
    "ackermann",
    "field_in_body",
    "heading_from_field",
    "roll_from_quaternion",
    "yaw_from_quaternion",
]

# Must match multicosim/mujoco/models/rover.xml (a test checks it).
WHEELBASE = 1.2  # m, rear axle to front axle
TRACK = 1.0  # m, between left and right wheel centres
WHEEL_RADIUS = 0.25  # m
AXLE_HEIGHT = 0.25  # m, height of the sensor point (rear axle centre) above the ground
WHEEL_WIDTH = 0.12  # m
REACH = math.hypot(WHEELBASE + WHEEL_RADIUS, (TRACK + WHEEL_WIDTH) / 2)
"""m: the radius about the rover's reference point (the rear axle's centre) that encloses
it, front wheels included: its extent in separation from other vehicles."""
# What the rear drive achieves, accelerating and braking (measured on the MuJoCo model).
ACCELERATION = 3.2  # m/s^2


def ackermann(speed: float, steering: float) -> tuple[float, float, float, float]:
    """Wheel set-points for a bicycle command: (left steer, right steer, left rate, right rate).

    The front wheels turn about a common centre on the rear axle line; the rear wheels spin
    at the rates that centre implies (rad/s), so no wheel scrubs in a steady turn.
    """
    rate = speed / WHEEL_RADIUS
    if abs(steering) < 1e-9:
        return 0.0, 0.0, rate, rate
    radius = WHEELBASE / math.tan(steering)  # signed: positive turns left
    half = TRACK / 2
    left = math.atan(WHEELBASE / (radius - half))
    right = math.atan(WHEELBASE / (radius + half))
    return left, right, rate * (radius - half) / radius, rate * (radius + half) / radius


def yaw_from_quaternion(q: tuple[float, float, float, float]) -> float:
    """Yaw (rad, counter-clockwise from east) of quaternion ``q`` = (w, x, y, z)."""
    w, x, y, z = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def roll_from_quaternion(q: tuple[float, float, float, float]) -> float:
    """Roll (rad, about the body's forward axis) of quaternion ``q`` = (w, x, y, z)."""
    w, x, y, z = q
    return math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))


def heading_from_field(x: float, y: float) -> float:
    """Heading (rad, counter-clockwise from east) from a level magnetometer's body reading.

    Earth's field points north; seen from a body turned by ``yaw`` it reads
    ``(sin(yaw), cos(yaw)) * horizontal strength`` on the forward and left axes.
    """
    return math.atan2(x, y)


def field_in_body(
    field: tuple[float, float, float], roll: float, pitch: float, yaw: float
) -> tuple[float, float, float]:
    """Earth's field (ENU) as a body-mounted magnetometer reads it."""
    # Rotate the world vector into the body frame: R(yaw) R(pitch) R(roll), transposed.
    fx, fy, fz = field
    cy, sy = math.cos(yaw), math.sin(yaw)
    x1, y1, z1 = cy * fx + sy * fy, -sy * fx + cy * fy, fz
    cp, sp = math.cos(pitch), math.sin(pitch)
    x2, y2, z2 = cp * x1 - sp * z1, y1, sp * x1 + cp * z1
    cr, sr = math.cos(roll), math.sin(roll)
    return x2, cr * y2 + sr * z2, -sr * y2 + cr * z2


@dataclasses.dataclass(frozen=True, kw_only=True)
class SensorNoise:
    """Standard deviations of the sensors' white noise; all zero gives ideal sensors.

    ``position`` (m), ``magnetometer`` (T), ``gyro`` (rad/s), ``accelerometer`` (m/s^2),
    ``wheel_speed`` (m/s). Noise is drawn from the component's seeded generator.
    """

    position: float = 0.0
    magnetometer: float = 0.0
    gyro: float = 0.0
    accelerometer: float = 0.0
    wheel_speed: float = 0.0

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not math.isfinite(value)
                or value < 0
            ):
                raise ConfigurationError(field.name, value, "a standard deviation >= 0")

    @classmethod
    def realistic(cls) -> SensorNoise:
        """Noise of inexpensive rover sensors (RTK-grade position, MEMS IMU and compass)."""
        return cls(
            position=0.02, magnetometer=2e-7, gyro=0.002, accelerometer=0.05, wheel_speed=0.01
        )

    @property
    def ideal(self) -> bool:
        """True when no sensor is noisy."""
        return not any(getattr(self, f.name) for f in dataclasses.fields(self))

    def scaled(self, factor: float) -> SensorNoise:
        """Every standard deviation times ``factor``."""
        if factor == 1.0:
            return self
        return SensorNoise(
            **{f.name: getattr(self, f.name) * factor for f in dataclasses.fields(self)}
        )


@dataclasses.dataclass(frozen=True, kw_only=True)
class RoverWorldConfig:
    """Everything a rover world needs: the physics world configuration and the sensor noise."""

    world: WorldConfig = dataclasses.field(default_factory=WorldConfig)
    noise: SensorNoise = dataclasses.field(default_factory=SensorNoise)

    def __post_init__(self) -> None:
        if not isinstance(self.world, WorldConfig):
            raise ConfigurationError("world", self.world, "a WorldConfig")
        if not isinstance(self.noise, SensorNoise):
            raise ConfigurationError("noise", self.noise, "a SensorNoise")
        check_sensor_topics(self.world, SENSOR_TOPICS)

    @property
    def sensor_noise(self) -> SensorNoise:
        """The noise the sensors get: ``noise`` scaled by the world's ``noise`` factor."""
        return self.noise.scaled(self.world.noise)
