"""What the injector can corrupt: each vehicle's sensor messages and their quantities.

A [`Sensor`][multicosim.attacks.sensors.Sensor] knows one message type: which quantities of it a
model can offset (their axes and units), how to read the message from a topic payload and write it
back, and how to apply an offset so that the message stays self-consistent (a GPS offset moves
the local position and latitude/longitude together; a heading offset rotates the measured
field). A zero offset is never applied: the message object passes through untouched.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..core.errors import ConfigurationError
from ..core.geo import LocalProjection
from ..mavlink.hil import Packer, Wire

__all__ = [
    "ALIASES",
    "BODY",
    "ENU",
    "HEADING",
    "SENSORS",
    "Quantity",
    "Sensor",
    "canonical",
    "moved",
    "register",
    "rotate",
    "sensor",
    "shift",
    "vehicles",
]

ENTRY_POINTS = "multicosim.sensors"


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

    vehicle: str
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
            from ..mavlink.hil import MavlinkPacket

            return MavlinkPacket
        return self.message

    def read(self, payload: Any) -> Any:
        """The message in ``payload`` (None if it holds none)."""
        if not self.hil:
            return payload
        from ..mavlink.hil import read

        return read(payload, self.message)

    def write(self, message: Any, wire: Wire, packer: Packer | None = None) -> Any:
        """The payload carrying ``message`` on ``wire`` (a frame numbered by ``packer``)."""
        if not self.hil:
            return message
        from ..mavlink.hil import write

        return write(message, wire, packer)


# -- geometry the vehicles' adapters share ----------------------------------------------------


def moved(lat: float, lon: float, north: float, east: float) -> tuple[float, float]:
    """Latitude and longitude (degrees) of the point ``north``/``east`` metres from lat, lon."""
    return LocalProjection(lat, lon).reproject(north, east)


def rotate(x: float, y: float, angle: float) -> tuple[float, float]:
    """A horizontal field reading as seen after the heading grew by ``angle``.

    Both vehicles compute their heading as ``atan2(x, y)`` of the body reading (the rover:
    x forward, y left, yaw counter-clockwise; PX4: x forward, y right, compass heading
    clockwise), so one rotation serves both.
    """
    c, s = math.cos(angle), math.sin(angle)
    return x * c + y * s, y * c - x * s


def shift(values: Sequence[float], delta: Sequence[float]) -> tuple[float, ...]:
    """``values`` offset by ``delta``, axis by axis."""
    return tuple(v + d for v, d in zip(values, delta, strict=True))


# -- the registry ---------------------------------------------------------------------------

ENU = ("east", "north", "up")
BODY = ("x", "y", "z")
HEADING = Quantity(("heading",), "rad")

# Each vehicle's sensors, their other names, and the module that registered them (imported
# again by an injector running in another process).
_SENSORS: dict[str, dict[str, Sensor]] = {}
SENSORS: dict[str, tuple[str, ...]] = {}
ALIASES: dict[str, dict[str, str]] = {}
_MODULES: dict[str, str] = {}


def register(
    vehicle: str,
    sensors: Sequence[Sensor],
    aliases: Mapping[str, str] | None = None,
    *,
    module: str | None = None,
) -> None:
    """Make ``sensors`` of ``vehicle`` injectable (``aliases``: other names users call them).

    ``module`` is the module whose import registers them (by default the module of the first
    sensor's ``apply``): an injector running in another process imports it. The vehicles
    register theirs when imported; a package can also name its registering module in the
    ``multicosim.sensors`` entry-point group, so that the injector finds it by the vehicle's
    name alone.
    """
    if not isinstance(vehicle, str) or not vehicle:
        raise ConfigurationError("vehicle", vehicle, "a non-empty vehicle name")
    for spec in sensors:
        if spec.vehicle != vehicle:
            raise ConfigurationError("sensors", spec.name, f"sensors of the {vehicle!r} vehicle")
    _SENSORS[vehicle] = {spec.name: spec for spec in sensors}
    SENSORS[vehicle] = tuple(spec.name for spec in sensors)
    ALIASES[vehicle] = dict(aliases or {})
    _MODULES[vehicle] = (
        module if module is not None else (sensors[0].apply.__module__ if sensors else "")
    )


def vehicles() -> tuple[str, ...]:
    """The vehicles whose sensors can be injected (registered or named by an entry point)."""
    from importlib.metadata import entry_points

    names = {ep.name for ep in entry_points(group=ENTRY_POINTS)}
    return tuple(sorted(names | set(_SENSORS)))


def module_of(vehicle: str) -> str:
    """The module that registered ``vehicle``'s sensors (imported again by an injector)."""
    _registered(vehicle)
    return _MODULES[vehicle]


def load(vehicle: str, module: str = "") -> None:
    """Make sure ``vehicle``'s sensors are registered: import ``module`` or its entry point."""
    if vehicle in _SENSORS:
        return
    if module:
        importlib.import_module(module)
        return
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINTS, name=vehicle):
        ep.load()


def _registered(vehicle: str) -> dict[str, Sensor]:
    load(vehicle)
    found = _SENSORS.get(vehicle)
    if found is None:
        raise ConfigurationError(
            "vehicle", vehicle, f"a vehicle with registered sensors, one of {vehicles()}"
        )
    return found


def canonical(vehicle: str, name: str) -> str:
    """The sensor's own name for ``name`` on ``vehicle``; raise ConfigurationError if unknown."""
    _registered(vehicle)
    known = SENSORS[vehicle]
    aliases = ALIASES[vehicle]
    resolved = aliases.get(name, name) if isinstance(name, str) else name
    if resolved not in known:
        allowed = f"a {vehicle} sensor, one of {known} (or {tuple(aliases)})"
        raise ConfigurationError("sensor", name, allowed)
    return str(resolved)


def sensor(vehicle: str, name: str) -> Sensor:
    """The [`Sensor`][multicosim.attacks.sensors.Sensor] ``name`` (or an alias) of ``vehicle``."""
    return _registered(vehicle)[canonical(vehicle, name)]
