"""The quadrotor world's topics: its sensors (as MAVLink's HIL messages) and its motor outputs.

PX4 (real and built-in) and ArduCopter fly the same quadrotor; its topics keep the names of
the simulator interface PX4 reads them through (``px4/imu``, ...), which traces, layouts and
injectors address.
"""

from __future__ import annotations

import msgspec

from ..core.errors import ConfigurationError
from ..physics.config import WorldConfig, check_sensor_topics

__all__ = ["SENSORS", "Topics", "world_topics"]


class Topics(msgspec.Struct, frozen=True):
    """Topic names of the simulator interface; remap them to insert injectors or bridges.

    The world publishes ``imu``, ``mag``, ``baro``, ``gps`` and ``truth`` (these defaults,
    moved by ``WorldConfig.sensor_topics``) and reads ``actuators``; the autopilot reads the
    four sensor topics and publishes ``actuators``. Giving the world and the autopilot
    different names lets a component sit in between (for example a GPS attack reading
    ``px4/gps`` and publishing ``px4/gps/attacked``).
    """

    imu: str = "px4/imu"
    mag: str = "px4/mag"
    baro: str = "px4/baro"
    gps: str = "px4/gps"
    actuators: str = "px4/actuators"
    truth: str = "px4/truth"

    def __post_init__(self) -> None:
        for field in self.__struct_fields__:
            value = getattr(self, field)
            if not isinstance(value, str) or not value:
                raise ConfigurationError(f"topics.{field}", value, "a non-empty topic name")


SENSORS = ("imu", "mag", "baro", "gps", "truth", "actuators")
"""The quadrotor world's topics by name: its sensors and its motor outputs
(``WorldConfig.sensor_topics`` keys)."""


def world_topics(world: WorldConfig) -> Topics:
    """The topics a quadrotor world configured by ``world`` publishes on and reads."""
    check_sensor_topics(world, dict.fromkeys(SENSORS, ""))
    if not world.sensor_topics:
        return _DEFAULT_TOPICS
    return Topics(**{**msgspec.structs.asdict(_DEFAULT_TOPICS), **world.sensor_topics})


_DEFAULT_TOPICS = Topics()
