"""What a trace of the rover scenario shows: typed topics, the map track, the 3-D pose, paths."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ..physics.config import WorldConfig
from ..trace import (
    LOCATION_CHANNEL,
    POSE_CHANNEL,
    POSE_IN_FRAME,
    Converted,
    TraceOptions,
    local_path,
    location_fix,
    message_path,
    pose_message,
)
from ._messages import (
    ABORT_TOPIC,
    COMMAND_TOPIC,
    SENSOR_TOPICS,
    Abort,
    Command,
    Imu,
    MagneticField,
    Position,
    WheelSpeed,
)

__all__ = ["trace_options"]

_TYPES: dict[str, type[Any]] = {
    "position": Position,
    "magnetometer": MagneticField,
    "imu": Imu,
    "wheel_speed": WheelSpeed,
}


def _fix(message: Any) -> tuple[float, float, float]:
    return message["latitude"], message["longitude"], message["altitude"]


def _enu(message: Any) -> tuple[float, float, float]:
    return message["x"], message["y"], message["z"]  # the world's local frame is ENU


class _Pose:
    """``foxglove.PoseInFrame`` from the world's position and IMU orientation (ENU ``map``)."""

    def __init__(self, position: str, imu: str) -> None:
        self.topics = (position, imu)
        self._position = position
        self._latest: Any = None

    def __call__(self, topic: str, time_ns: int, message: Any) -> Iterable[Converted]:
        if topic == self._position:
            self._latest = message
            return ()
        # The world publishes the position before the IMU in each instant: pair them then.
        p = self._latest
        if p is None:
            return ()
        pose = pose_message(time_ns, _enu(p), message["orientation"])
        return (Converted(POSE_CHANNEL, POSE_IN_FRAME, pose),)


def trace_options(world: WorldConfig) -> TraceOptions:
    """Types of every rover topic (remapped ones too) and the Foxglove channels.

    ``mcs/location``, ``mcs/pose`` and ``mcs/path/measured`` follow what the world's position
    sensor publishes (noisy from medium fidelity on; uncorrupted when an injector corrupts the
    controller's copy); ``mcs/location/sensed`` and ``mcs/path/sensed`` follow what the
    controller reads when the position is remapped.
    """
    types: dict[str, type[Any]] = {COMMAND_TOPIC: Command, ABORT_TOPIC: Abort}
    for name, topic in SENSOR_TOPICS.items():
        types[topic] = types[world.topic(name, topic)] = _TYPES[name]
    position = world.topic("position", SENSOR_TOPICS["position"])
    converters: list[Any] = [
        location_fix(position, _fix),
        _Pose(position, world.topic("imu", SENSOR_TOPICS["imu"])),
        local_path(position, _enu, label="measured"),
    ]
    if position != SENSOR_TOPICS["position"]:
        sensed = SENSOR_TOPICS["position"]
        converters.append(location_fix(sensed, _fix, channel=f"{LOCATION_CHANNEL}/sensed"))
        converters.append(local_path(sensed, _enu, label="sensed"))
    wheel = world.topic("wheel_speed", SENSOR_TOPICS["wheel_speed"])
    plots = [
        (
            "speed: command vs wheel odometry (m/s)",
            [message_path(COMMAND_TOPIC, "speed"), message_path(wheel, "speed")],
        )
    ]
    return TraceOptions(types=types, converters=converters, plots=plots)
