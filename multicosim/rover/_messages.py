"""Messages of the rover scenario: sensors, commands, the mission and its trajectory.

Units are SI throughout (metres, seconds, radians, tesla). The local frame is ENU (x east,
y north, z up); the body frame is x forward, y left, z up; a heading is the yaw angle
counter-clockwise from east. Every sensor message carries the simulated ``time`` it was
measured at.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from ..core.errors import ConfigurationError
from ..core.messages import Message

__all__ = [
    "ABORT_TOPIC",
    "COMMAND_TOPIC",
    "MAX_DISTANCE",
    "MAX_MISSION_TIME",
    "MAX_SPEED",
    "MAX_STEERING",
    "SENSOR_TOPICS",
    "Abort",
    "Command",
    "Imu",
    "MagneticField",
    "Mission",
    "Position",
    "SensedSample",
    "Trajectory",
    "WheelSpeed",
]

# Default topic of each sensor (sensor name -> topic); a world's ``sensor_topics`` moves
# one elsewhere so an injector can republish it here.
SENSOR_TOPICS: dict[str, str] = {
    "position": "rover/position",
    "magnetometer": "rover/magnetometer",
    "imu": "rover/imu",
    "wheel_speed": "rover/wheel_speed",
}
COMMAND_TOPIC = "rover/command"
ABORT_TOPIC = "rover/abort"

MAX_SPEED = 10.0  # m/s, what the drive can reach
MAX_STEERING = 0.5  # rad, the bicycle-model steering angle at full lock
# A mission's time and distances are bounded as PX4's time_limit is: what a controller
# records (its trajectory grows with the mission) and how long a send runs stay bounded.
MAX_MISSION_TIME = 3600.0  # s
MAX_DISTANCE = 10_000.0  # m, a leg of the mission


class Position(Message):
    """Where the rover is: local ENU metres and the same point as latitude/longitude/altitude."""

    time: float
    x: float
    y: float
    z: float
    latitude: float
    longitude: float
    altitude: float


class MagneticField(Message):
    """Magnetometer reading in the body frame (tesla)."""

    time: float
    x: float
    y: float
    z: float


class Imu(Message):
    """Accelerometer (m/s^2, specific force), gyroscope (rad/s) and orientation (w, x, y, z)."""

    time: float
    acceleration: tuple[float, float, float]
    angular_velocity: tuple[float, float, float]
    orientation: tuple[float, float, float, float]


class WheelSpeed(Message):
    """Rear wheel odometry: ground speed at the rear axle (m/s) and each wheel's rate (rad/s)."""

    time: float
    speed: float
    left: float
    right: float


class Command(Message):
    """Actuator command: target ground speed (m/s) and bicycle steering angle (rad, + = left)."""

    speed: float
    steering: float


class Abort(Message):
    """Published on ``rover/abort``: the controller stops the rover from any state."""

    reason: str = "abort requested"


def _check(field: str, value: object, ok: bool, allowed: str) -> None:
    if isinstance(value, bool) or not ok:
        raise ConfigurationError(field, value, allowed)


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


class Mission(Message):
    """What the FSA controller should do, validated on construction.

    Wait ``wait`` s, drive ``distance`` m straight at ``speed``, turn with steering angle
    ``steering`` (rad) at ``turn_speed`` (default: ``speed``) until the heading has changed
    by ``turn_angle`` (rad, positive = left), then drive ``final_distance`` m and stop there
    (slowing down at ``deceleration``). ``abort_at`` (s after the start) requests an abort;
    the turn gives up after ``turn_timeout`` s and the mission after ``timeout`` s. The
    controller runs, and samples the trajectory, at ``rate`` Hz.
    """

    speed: float
    wait: float = 5.0
    distance: float = 7.0
    turn_angle: float = math.radians(70.0)
    steering: float = MAX_STEERING
    turn_speed: float | None = None
    final_distance: float = 7.0
    deceleration: float = 2.0
    turn_timeout: float = 30.0
    timeout: float = 120.0
    abort_at: float | None = None
    rate: float = 20.0

    def __post_init__(self) -> None:
        _check(
            "speed",
            self.speed,
            _finite(self.speed) and 0 < self.speed <= MAX_SPEED,
            f"0 < speed <= {MAX_SPEED} m/s",
        )
        if self.turn_speed is not None:
            _check(
                "turn_speed",
                self.turn_speed,
                _finite(self.turn_speed) and 0 < self.turn_speed <= MAX_SPEED,
                f"None or 0 < turn_speed <= {MAX_SPEED} m/s",
            )
        for field, limit, unit in (
            ("wait", MAX_MISSION_TIME, "s"),
            ("distance", MAX_DISTANCE, "m"),
            ("final_distance", MAX_DISTANCE, "m"),
        ):
            value = getattr(self, field)
            _check(
                field,
                value,
                _finite(value) and 0 <= value <= limit,
                f"0 <= {field} <= {limit:g} {unit}",
            )
        _check(
            "turn_angle",
            self.turn_angle,
            _finite(self.turn_angle) and 0 < abs(self.turn_angle) <= math.pi,
            "0 < |turn_angle| <= pi rad (positive turns left)",
        )
        _check(
            "steering",
            self.steering,
            _finite(self.steering) and 0 < self.steering <= MAX_STEERING,
            f"0 < steering <= {MAX_STEERING} rad",
        )
        _check(
            "deceleration",
            self.deceleration,
            _finite(self.deceleration) and 0.1 <= self.deceleration <= 3.0,
            "0.1 <= deceleration <= 3 m/s^2 (what the drive can brake)",
        )
        for field in ("turn_timeout", "timeout"):
            value = getattr(self, field)
            _check(
                field,
                value,
                _finite(value) and 0 < value <= MAX_MISSION_TIME,
                f"0 < {field} <= {MAX_MISSION_TIME:g} s",
            )
        if self.abort_at is not None:
            _check(
                "abort_at",
                self.abort_at,
                _finite(self.abort_at) and 0 <= self.abort_at <= MAX_MISSION_TIME,
                f"None or 0 <= abort_at <= {MAX_MISSION_TIME:g} s after the start",
            )
        _check(
            "rate",
            self.rate,
            _finite(self.rate) and 10.0 <= self.rate <= 1000.0,
            "10 <= rate <= 1000 Hz",
        )

    @property
    def cruise_turn_speed(self) -> float:
        """The speed during the turn."""
        return self.speed if self.turn_speed is None else self.turn_speed


class SensedSample(Message):
    """One point of the trajectory, as the controller sensed it."""

    time: float
    x: float
    y: float
    z: float
    heading: float
    roll: float
    speed: float
    state: str


class Trajectory(Message):
    """The controller's reply: samples at the mission's rate and how the mission ended.

    ``final_state`` is the automaton's terminal state (``done``, ``aborted`` or
    ``timed_out``); ``completed`` is true when the whole plan was driven.
    """

    samples: list[SensedSample]
    final_state: str
    completed: bool
    reason: str = ""
    start_time: float = 0.0

    def __iter__(self) -> Iterator[SensedSample]:
        return iter(self.samples)

    def __len__(self) -> int:
        return len(self.samples)

    @property
    def final(self) -> SensedSample:
        """The last sample (the rover at rest, once the mission ended)."""
        return self.samples[-1]

    @property
    def times(self) -> list[float]:
        """SensedSample times (simulated seconds)."""
        return [s.time for s in self.samples]

    def states(self) -> list[str]:
        """The automaton states visited, in order, without repetitions."""
        seen: list[str] = []
        for s in self.samples:
            if not seen or seen[-1] != s.state:
                seen.append(s.state)
        return seen
