"""PX4's sensors (its HIL messages) as [`multicosim.attacks`][multicosim.attacks] corrupts them:
what each reading's quantities are and how an offset moves them (registered on import).

The same adapters work on both wires (native Structs, packed MAVLink frames).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import msgspec

from ..attacks.sensors import BODY, ENU, HEADING, Quantity, Sensor, moved, register, rotate, shift
from ..core.geo import pressure_hpa
from ..mavlink.hil import IMU_FIELDS, MAG_FIELDS, HilGps, HilSensor

__all__ = ["sensors"]


def _px4_gps(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    east, north, up = d
    if quantity == "position":
        lat, lon = moved(msg.lat * 1e-7, msg.lon * 1e-7, north, east)
        return msgspec.structs.replace(
            msg,
            lat=round(lat * 1e7),
            lon=round(lon * 1e7),
            alt=msg.alt + round(up * 1000),
        )
    # Velocity: the message carries NED cm/s, plus ground speed and course over ground.
    vn, ve, vd = msg.vn + round(north * 100), msg.ve + round(east * 100), msg.vd - round(up * 100)
    cog = round(math.degrees(math.atan2(ve, vn)) * 100) % 36000
    return msgspec.structs.replace(msg, vn=vn, ve=ve, vd=vd, vel=round(math.hypot(vn, ve)), cog=cog)


def _px4_mag(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    if msg.fields_updated & MAG_FIELDS != MAG_FIELDS:
        return msg  # an IMU or baro sample sharing the topic: no field in it
    if quantity == "heading":
        x, y = rotate(msg.xmag, msg.ymag, d[0])
        return msgspec.structs.replace(msg, xmag=x, ymag=y)
    x, y, z = shift((msg.xmag, msg.ymag, msg.zmag), d)
    return msgspec.structs.replace(msg, xmag=x, ymag=y, zmag=z)


def _px4_baro(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    if not msg.fields_updated & 0x800:  # HIL_SENSOR_UPDATED_PRESSALT
        return msg
    alt = msg.pressure_alt + d[0]
    return msgspec.structs.replace(msg, pressure_alt=alt, abs_pressure=pressure_hpa(alt))


def _px4_imu(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    if msg.fields_updated & IMU_FIELDS != IMU_FIELDS:
        return msg
    names = ("xacc", "yacc", "zacc") if quantity == "acceleration" else ("xgyro", "ygyro", "zgyro")
    return msgspec.structs.replace(
        msg, **{n: getattr(msg, n) + v for n, v in zip(names, d, strict=True)}
    )


def sensors() -> list[Sensor]:
    return [
        Sensor(
            "px4",
            "gps",
            HilGps,
            {"position": Quantity(ENU, "m"), "velocity": Quantity(ENU, "m/s")},
            _px4_gps,
            hil=True,
        ),
        Sensor(
            "px4",
            "mag",
            HilSensor,
            {"heading": HEADING, "field": Quantity(("x", "y", "z"), "gauss")},
            _px4_mag,
            hil=True,
        ),
        Sensor("px4", "baro", HilSensor, {"altitude": Quantity(("up",), "m")}, _px4_baro, hil=True),
        Sensor(
            "px4",
            "imu",
            HilSensor,
            {
                "angular_velocity": Quantity(BODY, "rad/s"),
                "acceleration": Quantity(BODY, "m/s^2"),
            },
            _px4_imu,
            hil=True,
        ),
    ]


register("px4", sensors(), {"position": "gps", "magnetometer": "mag", "compass": "mag"})
