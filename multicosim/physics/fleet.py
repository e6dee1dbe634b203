"""Several vehicles in one MuJoCo world: their start poses, one model built from their models,
and each vehicle's view of the shared state.

Every vehicle's MJCF joins one model through MuJoCo's model-editing API: each top-level body
of its worldbody is attached, under the vehicle's name as a prefix (``alpha/vehicle``,
``alpha/motor0``), at its start pose; what the vehicle's model has on the worldbody itself (a
ground plane, lights) is the environment, which the world provides once. A vehicle then sees
the shared state through a [`MemberPhysics`][multicosim.physics.MemberPhysics]: its sensors,
actuators and objects by their own names, its own ``qpos``, ``qvel`` and ``ctrl``, its own proximity
to the obstacles.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError
from ..core.geo import LocalProjection

if TYPE_CHECKING:
    from ..core.geo import Home

__all__ = [
    "CONTACT_GEOM",
    "Pose",
    "check_name",
    "fleet_topic",
    "frame_quat",
    "member_names",
    "resolve_pose",
]

CONTACT_GEOM = "vehicle_contact"
"""The name (under the vehicle's) of the sphere by which vehicles touch each other."""

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,31}$")


def check_name(name: object, field: str = "vehicles") -> str:
    """``name`` as a vehicle's name (letters, digits, ``_``, ``-``; a letter first)."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise ConfigurationError(
            field, name, "vehicle names of letters, digits, '_' and '-' (a letter first)"
        )
    return name


@dataclasses.dataclass(frozen=True, kw_only=True)
class Pose:
    """Where a vehicle starts: ``north``/``east``/``up`` metres from home (or ``lat``/``lon``
    degrees, WGS84) and ``yaw``, its heading in degrees clockwise from north (None: as its
    model places it). ``up`` raises it above where its model stands it."""

    north: float = 0.0
    east: float = 0.0
    up: float = 0.0
    yaw: float | None = None
    lat: float | None = None
    lon: float | None = None

    def __post_init__(self) -> None:
        for field in ("north", "east", "up"):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ConfigurationError(field, value, "a finite number of metres")
            if not math.isfinite(value) or abs(value) > 100_000.0:
                raise ConfigurationError(field, value, "a finite number within 100 km of home")
        if self.yaw is not None and (
            isinstance(self.yaw, bool)
            or not isinstance(self.yaw, int | float)
            or not -360.0 <= self.yaw <= 360.0
        ):
            raise ConfigurationError("yaw", self.yaw, "None or degrees from -360 to 360")
        if (self.lat is None) != (self.lon is None):
            raise ConfigurationError("lat", self.lat, "both lat and lon, or neither")
        if self.lat is not None and (self.north or self.east):
            raise ConfigurationError(
                "north", self.north, "0 when lat and lon give the position (one or the other)"
            )
        if self.lat is not None:
            assert self.lon is not None
            for field, value, bound in (("lat", self.lat, 90.0), ("lon", self.lon, 180.0)):
                if isinstance(value, bool) or not isinstance(value, int | float):
                    raise ConfigurationError(field, value, "degrees")
                if not -bound <= value <= bound:
                    raise ConfigurationError(field, value, f"degrees from -{bound:g} to {bound:g}")


def resolve_pose(pose: Pose, home: Home) -> tuple[float, float, float, float | None]:
    """``pose`` as (north, east, up, yaw) metres from ``home``."""
    if pose.lat is not None and pose.lon is not None:
        north, east = LocalProjection.at(home).project(pose.lat, pose.lon)
        return north, east, pose.up, pose.yaw
    return pose.north, pose.east, pose.up, pose.yaw


def frame_quat(yaw: float | None) -> list[float]:
    """The rotation of a frame that turns a model whose forward is east (MuJoCo's x) to face
    ``yaw`` degrees clockwise from north (identity for None)."""
    if yaw is None:
        return [1.0, 0.0, 0.0, 0.0]
    # ENU: a turn of (90 - yaw) degrees about up takes x (east) to the heading.
    turn = math.radians(90.0 - yaw)
    return [math.cos(turn / 2), 0.0, 0.0, math.sin(turn / 2)]


def member_names(vehicles: Mapping[str, Any]) -> list[str]:
    """The fleet's names, checked, in the mapping's order."""
    if not vehicles:
        raise ConfigurationError("vehicles", dict(vehicles), "at least one named vehicle")
    return [check_name(name) for name in vehicles]


def fleet_topic(member: str, default: str) -> str:
    """Where vehicle ``member`` of a fleet has a topic its model names ``default``: under its
    name, in place of the model's own first segment (``px4/imu`` -> ``alpha/imu``)."""
    _, sep, rest = default.partition("/")
    return f"{member}/{rest if sep else default}"
