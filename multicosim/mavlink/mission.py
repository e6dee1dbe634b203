"""A MAVLink autopilot's mission: what a ground station is told to fly and what it records,
validated on construction (PX4's and ArduPilot's scenarios share them).

Everything here is a frozen msgspec Struct: it is a message (sent to the firmware node, or
passed as JSON to a component process) and a configuration (invalid values raise
[`ConfigurationError`][multicosim.ConfigurationError] naming the field before anything starts).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import msgspec

from ..core.errors import ConfigurationError, check_number
from ..core.geo import Home, LocalProjection
from .dialect import (
    CMD_LAND,
    CMD_RTL,
    CMD_TAKEOFF,
    CMD_WAYPOINT,
    FRAME_GLOBAL_REL,
    FRAME_MISSION,
)
from .plan import Plan, PlanItem, read_plan, write_plan

__all__ = [
    "Collision",
    "Configuration",
    "FlightSample",
    "Geofence",
    "Home",
    "MissionResult",
    "Waypoint",
    "WaypointReached",
]

MissionEnd = Literal["land", "rtl", "hold"]


class Geofence(msgspec.Struct, frozen=True):
    """A cylinder around home that missions must stay in (PX4's GF_MAX_HOR/VER_DIST)."""

    radius: float = 1000.0
    max_alt: float = 120.0

    def __post_init__(self) -> None:
        check_number("geofence.radius", self.radius, 0.0, 100_000.0, open_lo=True)
        check_number("geofence.max_alt", self.max_alt, 0.0, 10_000.0, open_lo=True)


class Waypoint(msgspec.Struct, frozen=True):
    """A mission waypoint: WGS84 latitude/longitude (degrees), altitude above home (m)."""

    lat: float
    lon: float
    alt: float

    def __post_init__(self) -> None:
        check_number("lat", self.lat, -90.0, 90.0)
        check_number("lon", self.lon, -180.0, 180.0)
        check_number("alt", self.alt, 0.0, 10_000.0)

    @classmethod
    def local(cls, north: float, east: float, alt: float, home: Home | None = None) -> Waypoint:
        """The waypoint ``north``/``east`` metres from ``home`` (the world's home; default
        PX4's), ``alt`` metres above it: placed as obstacles are.

        ```python
        px4.Waypoint.local(north=30.0, east=0.0, alt=10.0)
        ```
        """
        check_number("north", north)
        check_number("east", east)
        home = home or Home()
        lat, lon = LocalProjection(home.lat, home.lon).reproject(north, east)
        return cls(lat, lon, alt)


class Configuration(msgspec.Struct, frozen=True):
    """What the ground station is told to fly (the paper's ``px4.Configuration(mission)``).

    ``end``: after the last waypoint, ``"land"`` there, return and land (``"rtl"``) or hold
    position (``"hold"``). ``takeoff_alt`` defaults to the first waypoint's altitude.
    ``time_limit`` bounds the mission in simulated seconds: past it the result is incomplete.
    ``plan``, when given ([`from_plan`][multicosim.mavlink.mission.Configuration.from_plan]), is
    what the vehicle flies, item for item, with its geofence and rally points; ``mission`` then
    lists its waypoints.
    """

    mission: list[Waypoint]
    end: MissionEnd = "land"
    cruise_speed: float = 5.0
    acceptance_radius: float = 2.0
    takeoff_alt: float | None = None
    time_limit: float = 600.0
    plan: Plan | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.mission, list | tuple) or not self.mission:
            raise ConfigurationError("mission", self.mission, "a non-empty list of px4.Waypoint")
        for i, wp in enumerate(self.mission):
            if not isinstance(wp, Waypoint):
                raise ConfigurationError(f"mission[{i}]", wp, "a px4.Waypoint")
        if self.end not in ("land", "rtl", "hold"):
            raise ConfigurationError("end", self.end, "'land', 'rtl' or 'hold'")
        check_number("cruise_speed", self.cruise_speed, 0.5, 20.0)
        check_number("acceptance_radius", self.acceptance_radius, 0.3, 50.0)
        if self.takeoff_alt is not None:
            check_number("takeoff_alt", self.takeoff_alt, 1.0, 1000.0)
        check_number("time_limit", self.time_limit, 0.0, 86_400.0, open_lo=True)
        if self.plan is not None and not isinstance(self.plan, Plan):
            raise ConfigurationError("plan", self.plan, "None or a plan read by from_plan")

    @classmethod
    def from_plan(
        cls,
        path: str | Path,
        *,
        acceptance_radius: float = 2.0,
        time_limit: float = 600.0,
    ) -> Configuration:
        """The mission of a QGroundControl ``.plan`` file, with its geofence and rally points.

        The vehicle flies the plan's items as they are; the configuration's waypoints are
        its waypoint and loiter items and a landing's own position (at altitude 0), its
        cruise speed the plan's ``hoverSpeed`` and its end
        the plan's last landing or return item (``"hold"`` without one).
        """
        plan = read_plan(path)
        mission = []
        for i in plan.waypoints():
            it = plan.items[i]
            # A landing's altitude is the ground's, whatever the file says.
            alt = 0.0 if it.command == CMD_LAND else plan.relative_alt(it)
            if alt < 0:
                raise ConfigurationError(
                    f"{path}: mission.items[{i}].params[6]", it.alt, "an altitude above home"
                )
            mission.append(Waypoint(lat=it.lat, lon=it.lon, alt=alt))
        if not mission:
            raise ConfigurationError(
                f"{path}: mission.items", len(plan.items), "a mission with at least one waypoint"
            )
        return cls(
            mission,
            end=plan.end(),
            cruise_speed=plan.hover_speed,
            acceptance_radius=acceptance_radius,
            time_limit=time_limit,
            plan=plan,
        )

    def to_plan(self, path: str | Path, home: Home | None = None) -> None:
        """Write this mission as a QGroundControl ``.plan`` file.

        A configuration read from a plan writes that plan; any other is written as the
        ground station flies it (takeoff, waypoints, land or return) from ``home``.
        """
        if self.plan is not None:
            write_plan(self.plan, path)
            return
        if not isinstance(home, Home):
            raise ConfigurationError("home", home, "a Home: where the plan's vehicle starts")
        write_plan(self._as_plan(home), path)

    def _as_plan(self, home: Home) -> Plan:
        rel, nan = FRAME_GLOBAL_REL, math.nan
        wps = self.mission
        takeoff = self.takeoff_alt if self.takeoff_alt is not None else wps[0].alt
        items = [PlanItem(CMD_TAKEOFF, rel, (0.0, 0.0, 0.0, nan, home.lat, home.lon, takeoff))]
        acc = self.acceptance_radius
        items += [
            PlanItem(CMD_WAYPOINT, rel, (0.0, acc, 0.0, nan, w.lat, w.lon, w.alt)) for w in wps
        ]
        last = wps[-1]
        if self.end == "land":
            items.append(PlanItem(CMD_LAND, rel, (0.0, 0.0, 0.0, nan, last.lat, last.lon, 0.0)))
        elif self.end == "rtl":
            items.append(PlanItem(CMD_RTL, FRAME_MISSION, (0.0,) * 7))
        return Plan(
            items=items,
            home=(home.lat, home.lon, home.alt),
            hover_speed=self.cruise_speed,
        )

    def check_geofence(self, home: Home, fence: Geofence) -> None:
        """Raise ConfigurationError naming the first waypoint outside ``fence`` around ``home``."""
        proj = LocalProjection(home.lat, home.lon)
        for i, wp in enumerate(self.mission):
            north, east = proj.project(wp.lat, wp.lon)
            dist = math.hypot(north, east)
            if dist > fence.radius:
                raise ConfigurationError(
                    f"mission[{i}]",
                    wp,
                    f"a waypoint within the geofence ({dist:.0f} m from home > "
                    f"radius {fence.radius:g} m)",
                )
            if wp.alt > fence.max_alt:
                raise ConfigurationError(
                    f"mission[{i}].alt", wp.alt, f"at most the geofence's {fence.max_alt:g} m"
                )
        if self.takeoff_alt is not None and self.takeoff_alt > fence.max_alt:
            raise ConfigurationError(
                "takeoff_alt", self.takeoff_alt, f"at most the geofence's {fence.max_alt:g} m"
            )


class FlightSample(msgspec.Struct, frozen=True, kw_only=True):
    """One trajectory sample as the ground station sees it, plus the world's ground truth.

    ``lat``/``lon`` (deg), ``alt`` (m above home) and ``north``/``east``/``up`` (m from
    home; ``x``/``y``/``z`` are the same in MAVLink's north-east-down) are the
    autopilot's estimate as it last reported it; ``true_*`` are the world's truth (they
    differ when sensors lie). The ground station takes one sample per period (20 Hz at
    medium fidelity and above, 10 Hz at low).
    ``mode`` is the autopilot's mode name (PX4's ``AUTO.MISSION``, ArduPilot's ``AUTO``),
    ``current`` the MAVLink sequence number
    of the current mission item (0: takeoff, 1..n: the configured waypoints, then land/RTL).
    ``clearance`` is the true 3-D distance (m) from the vehicle's body to the nearest
    obstacle, ``footprint_clearance`` the 2-D distance from its footprint to the nearest
    obstacle's footprint (both infinite in a world without obstacles, negative inside one);
    ``collision`` says it touches an obstacle.
    """

    time: float
    lat: float
    lon: float
    alt: float
    x: float
    y: float
    z: float
    vx: float
    vy: float
    vz: float
    roll: float
    pitch: float
    yaw: float
    mode: str
    armed: bool
    current: int
    true_lat: float
    true_lon: float
    true_alt: float
    clearance: float = math.inf
    footprint_clearance: float = math.inf
    collision: bool = False

    # The public convention (multicosim.core.geo): north, east, up by name. x/y/z stay
    # MAVLink's north-east-down, as LOCAL_POSITION_NED reports them.
    @property
    def north(self) -> float:
        """The estimated position, metres north of home (``x``)."""
        return self.x

    @property
    def east(self) -> float:
        """The estimated position, metres east of home (``y``)."""
        return self.y

    @property
    def up(self) -> float:
        """The estimated position, metres above home (``-z``)."""
        return -self.z


class Collision(msgspec.Struct, frozen=True, kw_only=True):
    """The vehicle hit ``obstacle`` (its index in ``WorldConfig.obstacles``; ``name`` its
    name there, empty if it has none) at simulated ``time`` (s), moving at ``speed`` (m/s)."""

    time: float
    obstacle: int
    speed: float
    name: str = ""


class WaypointReached(msgspec.Struct, frozen=True, kw_only=True):
    """Waypoint ``index`` (into the configured mission) was reached at simulated ``time``."""

    index: int
    time: float


class MissionResult(msgspec.Struct, frozen=True, kw_only=True):
    """The reply to a Configuration: trajectory, reached waypoints, outcome.

    ``completed`` says whether the mission ran to its configured end (landed and disarmed,
    or holding at the last waypoint); ``reason`` says why not. ``messages`` holds the
    autopilot's STATUSTEXT messages; ``firmware_version`` the flight software version it
    reported (AUTOPILOT_VERSION, e.g. ``"1.15.4"``). ``collision`` is the first collision
    with an obstacle (the mission ends there), ``min_clearance`` the smallest 3-D clearance
    the trajectory saw (infinite without obstacles).
    """

    trajectory: list[FlightSample]
    reached: list[WaypointReached]
    completed: bool
    reason: str
    start_time: float
    end_time: float
    landed: bool
    armed: bool
    messages: list[str] = msgspec.field(default_factory=list)
    firmware_version: str = ""
    collision: Collision | None = None
    min_clearance: float = math.inf

    @property
    def duration(self) -> float:
        """Simulated seconds the mission took."""
        return self.end_time - self.start_time

    def path_gap(self, other: MissionResult, *, above: float = 0.5) -> tuple[float, float]:
        """Mean and max horizontal distance (m) from this flight's true path to ``other``'s.

        Each true position more than ``above`` m up is measured to the nearest airborne true
        position of ``other``: how far apart two flights went, whenever each got there.
        """
        if not self.trajectory or not other.trajectory:
            raise ConfigurationError("trajectory", [], "two flights with samples")
        first = self.trajectory[0]
        projection = LocalProjection(first.true_lat, first.true_lon)

        def track(result: MissionResult) -> list[tuple[float, float]]:
            return [
                projection.project(s.true_lat, s.true_lon)
                for s in result.trajectory
                if s.true_alt > above
            ]

        mine, theirs = track(self), track(other)
        if not mine or not theirs:
            raise ConfigurationError("trajectory", [], f"flights that rose above {above:g} m")
        gaps = [min(math.dist(p, q) for q in theirs) for p in mine]
        return sum(gaps) / len(gaps), max(gaps)
