"""The rover's sensors as [`multicosim.attacks`][multicosim.attacks] corrupts them: what each
reading's quantities are and how an offset moves them (registered on import).

Positions are metres east/north/up; a heading offset rotates the magnetometer's field.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import msgspec

from ..attacks.sensors import BODY, ENU, HEADING, Quantity, Sensor, moved, register, rotate, shift
from ._messages import Imu, MagneticField, Position, WheelSpeed

__all__ = ["sensors"]


def _rover_position(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    east, north, up = d
    lat, lon = moved(msg.latitude, msg.longitude, north, east)
    return msgspec.structs.replace(
        msg,
        x=msg.x + east,
        y=msg.y + north,
        z=msg.z + up,
        latitude=lat,
        longitude=lon,
        altitude=msg.altitude + up,
    )


def _rover_magnetometer(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    if quantity == "heading":
        x, y = rotate(msg.x, msg.y, d[0])
        return msgspec.structs.replace(msg, x=x, y=y)
    x, y, z = shift((msg.x, msg.y, msg.z), d)
    return msgspec.structs.replace(msg, x=x, y=y, z=z)


def _rover_imu(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    return msgspec.structs.replace(msg, **{quantity: shift(getattr(msg, quantity), d)})


def _rover_wheel_speed(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    return msgspec.structs.replace(msg, speed=msg.speed + d[0])


def sensors() -> list[Sensor]:
    return [
        Sensor("rover", "position", Position, {"position": Quantity(ENU, "m")}, _rover_position),
        Sensor(
            "rover",
            "magnetometer",
            MagneticField,
            {"heading": HEADING, "field": Quantity(BODY, "T")},
            _rover_magnetometer,
        ),
        Sensor(
            "rover",
            "imu",
            Imu,
            {
                "angular_velocity": Quantity(BODY, "rad/s"),
                "acceleration": Quantity(BODY, "m/s^2"),
            },
            _rover_imu,
        ),
        Sensor(
            "rover",
            "wheel_speed",
            WheelSpeed,
            {"speed": Quantity(("speed",), "m/s")},
            _rover_wheel_speed,
        ),
    ]


register("rover", sensors(), {"gps": "position", "mag": "magnetometer", "compass": "magnetometer"})
