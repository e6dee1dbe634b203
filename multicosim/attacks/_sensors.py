"""What the injector can corrupt: each vehicle's sensor messages and their quantities.

A :class:`Sensor` knows one message type: which quantities of it a model can offset
(their axes and units), how to read the message from a topic payload and write it back,
and how to apply an offset so that the message stays self-consistent (a GPS offset moves
the local position and latitude/longitude together; a heading offset rotates the measured
field). A zero offset is never applied: the message object passes through untouched.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal

import msgspec

from .._errors import ConfigurationError
from ..geo import LocalProjection

__all__ = ["ALIASES", "SENSORS", "VEHICLES", "Quantity", "Sensor", "Vehicle", "sensor"]

Vehicle = Literal["rover", "px4"]
VEHICLES: tuple[Vehicle, ...] = ("rover", "px4")
Wire = Literal["native", "mavlink"]


@dataclasses.dataclass(frozen=True)
class Quantity:
    """A part of a reading a model can offset: its axes (in order) and unit."""

    axes: tuple[str, ...]
    unit: str

    @property
    def size(self) -> int:
        """Number of axes."""
        return len(self.axes)


Apply = Callable[[Any, str, Sequence[float]], Any]


@dataclasses.dataclass(frozen=True)
class Sensor:
    """One sensor message of one vehicle and what models can do to it."""

    vehicle: Vehicle
    name: str
    message: type[Any]
    quantities: Mapping[str, Quantity]
    apply: Apply
    hil: bool = False  # a PX4 HIL payload: native Struct or packed MAVLink frame

    @property
    def default(self) -> str:
        """The quantity models act on unless they name one."""
        return next(iter(self.quantities))

    def payload_type(self, wire: Wire) -> type[Any]:
        """The type to subscribe the sensor's topic with on ``wire``."""
        if self.hil and wire == "mavlink":
            from ..px4._hil import MavlinkPacket

            return MavlinkPacket
        return self.message

    def read(self, payload: Any) -> Any:
        """The message in ``payload`` (None if it holds none)."""
        if not self.hil:
            return payload
        from ..px4._hil import read

        return read(payload, self.message)

    def write(self, message: Any, wire: Wire) -> Any:
        """The payload carrying ``message`` on ``wire``."""
        if not self.hil:
            return message
        from ..px4._hil import write

        return write(message, wire)


# -- shared geometry ------------------------------------------------------------------------


def _moved(lat: float, lon: float, north: float, east: float) -> tuple[float, float]:
    """Latitude and longitude (degrees) of the point ``north``/``east`` metres from lat, lon."""
    return LocalProjection(lat, lon).reproject(north, east)


def _rotate(x: float, y: float, angle: float) -> tuple[float, float]:
    """A horizontal field reading as seen after the heading grew by ``angle``.

    Both vehicles compute their heading as ``atan2(x, y)`` of the body reading (the rover:
    x forward, y left, yaw counter-clockwise; PX4: x forward, y right, compass heading
    clockwise), so one rotation serves both.
    """
    c, s = math.cos(angle), math.sin(angle)
    return x * c + y * s, y * c - x * s


def _shift(values: Sequence[float], delta: Sequence[float]) -> tuple[float, ...]:
    return tuple(v + d for v, d in zip(values, delta, strict=True))


# -- the rover ------------------------------------------------------------------------------


def _rover_position(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    east, north, up = d
    lat, lon = _moved(msg.latitude, msg.longitude, north, east)
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
        x, y = _rotate(msg.x, msg.y, d[0])
        return msgspec.structs.replace(msg, x=x, y=y)
    x, y, z = _shift((msg.x, msg.y, msg.z), d)
    return msgspec.structs.replace(msg, x=x, y=y, z=z)


def _rover_imu(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    return msgspec.structs.replace(msg, **{quantity: _shift(getattr(msg, quantity), d)})


def _rover_wheel_speed(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    return msgspec.structs.replace(msg, speed=msg.speed + d[0])


# -- PX4 (HIL messages) ---------------------------------------------------------------------


def _px4_gps(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    east, north, up = d
    if quantity == "position":
        lat, lon = _moved(msg.lat * 1e-7, msg.lon * 1e-7, north, east)
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
    from ..px4._hil import MAG_FIELDS

    if msg.fields_updated & MAG_FIELDS != MAG_FIELDS:
        return msg  # an IMU or baro sample sharing the topic: no field in it
    if quantity == "heading":
        x, y = _rotate(msg.xmag, msg.ymag, d[0])
        return msgspec.structs.replace(msg, xmag=x, ymag=y)
    x, y, z = _shift((msg.xmag, msg.ymag, msg.zmag), d)
    return msgspec.structs.replace(msg, xmag=x, ymag=y, zmag=z)


def _px4_baro(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    from ..geo import pressure_hpa

    if not msg.fields_updated & 0x800:  # HIL_SENSOR_UPDATED_PRESSALT
        return msg
    alt = msg.pressure_alt + d[0]
    return msgspec.structs.replace(msg, pressure_alt=alt, abs_pressure=pressure_hpa(alt))


def _px4_imu(msg: Any, quantity: str, d: Sequence[float]) -> Any:
    from ..px4._hil import IMU_FIELDS

    if msg.fields_updated & IMU_FIELDS != IMU_FIELDS:
        return msg
    names = ("xacc", "yacc", "zacc") if quantity == "acceleration" else ("xgyro", "ygyro", "zgyro")
    return msgspec.structs.replace(
        msg, **{n: getattr(msg, n) + v for n, v in zip(names, d, strict=True)}
    )


# -- the registry ---------------------------------------------------------------------------

_ENU = ("east", "north", "up")
_BODY = ("x", "y", "z")
_HEADING = Quantity(("heading",), "rad")


def _rover_sensors() -> dict[str, Sensor]:
    from ..rover._messages import Imu, MagneticField, Position, WheelSpeed

    return {
        "position": Sensor(
            "rover", "position", Position, {"position": Quantity(_ENU, "m")}, _rover_position
        ),
        "magnetometer": Sensor(
            "rover",
            "magnetometer",
            MagneticField,
            {"heading": _HEADING, "field": Quantity(_BODY, "T")},
            _rover_magnetometer,
        ),
        "imu": Sensor(
            "rover",
            "imu",
            Imu,
            {
                "angular_velocity": Quantity(_BODY, "rad/s"),
                "acceleration": Quantity(_BODY, "m/s^2"),
            },
            _rover_imu,
        ),
        "wheel_speed": Sensor(
            "rover",
            "wheel_speed",
            WheelSpeed,
            {"speed": Quantity(("speed",), "m/s")},
            _rover_wheel_speed,
        ),
    }


def _px4_sensors() -> dict[str, Sensor]:
    from ..px4._hil import HilGps, HilSensor

    return {
        "gps": Sensor(
            "px4",
            "gps",
            HilGps,
            {"position": Quantity(_ENU, "m"), "velocity": Quantity(_ENU, "m/s")},
            _px4_gps,
            hil=True,
        ),
        "mag": Sensor(
            "px4",
            "mag",
            HilSensor,
            {"heading": _HEADING, "field": Quantity(("x", "y", "z"), "gauss")},
            _px4_mag,
            hil=True,
        ),
        "baro": Sensor(
            "px4", "baro", HilSensor, {"altitude": Quantity(("up",), "m")}, _px4_baro, hil=True
        ),
        "imu": Sensor(
            "px4",
            "imu",
            HilSensor,
            {
                "angular_velocity": Quantity(_BODY, "rad/s"),
                "acceleration": Quantity(_BODY, "m/s^2"),
            },
            _px4_imu,
            hil=True,
        ),
    }


# Sensor names (and what else users call them) of each vehicle.
SENSORS: dict[Vehicle, tuple[str, ...]] = {
    "rover": ("position", "magnetometer", "imu", "wheel_speed"),
    "px4": ("gps", "mag", "baro", "imu"),
}
ALIASES: dict[Vehicle, dict[str, str]] = {
    "rover": {"gps": "position", "mag": "magnetometer", "compass": "magnetometer"},
    "px4": {"position": "gps", "magnetometer": "mag", "compass": "mag"},
}
_REGISTRY: dict[Vehicle, Callable[[], dict[str, Sensor]]] = {
    "rover": _rover_sensors,
    "px4": _px4_sensors,
}


def canonical(vehicle: str, name: str) -> str:
    """The sensor's own name for ``name`` on ``vehicle``; raise ConfigurationError if unknown."""
    if vehicle not in VEHICLES:
        raise ConfigurationError("vehicle", vehicle, f"one of {VEHICLES}")
    known = SENSORS[vehicle]
    aliases = ALIASES[vehicle]
    resolved = aliases.get(name, name) if isinstance(name, str) else name
    if resolved not in known:
        allowed = f"a {vehicle} sensor, one of {known} (or {tuple(aliases)})"
        raise ConfigurationError("sensor", name, allowed)
    return str(resolved)


def sensor(vehicle: str, name: str) -> Sensor:
    """The :class:`Sensor` ``name`` (or an alias) of ``vehicle``."""
    resolved = canonical(vehicle, name)
    return _registry(vehicle)[resolved]


@functools.cache
def _registry(vehicle: str) -> dict[str, Sensor]:
    # Built on first use: the rover and PX4 message modules load only when needed.
    return _REGISTRY[vehicle]()  # type: ignore[index]
