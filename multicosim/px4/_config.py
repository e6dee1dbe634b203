"""Configuration and result types of the PX4 scenario, validated on construction.

Everything here is a frozen msgspec Struct: it is a message (sent to the firmware node, or
passed as JSON to a component process) and a configuration (invalid values raise
:class:`~multicosim.ConfigurationError` naming the field before anything starts).
"""

from __future__ import annotations

import math
from typing import Literal

import msgspec

from .._errors import ConfigurationError
from ._geo import LocalProjection

__all__ = [
    "Configuration",
    "Geofence",
    "Home",
    "MissionResult",
    "MuJoCo",
    "Sample",
    "Topics",
    "Waypoint",
    "WaypointReached",
]

Integrator = Literal["Euler", "RK4", "implicit", "implicitfast"]
Solver = Literal["PGS", "CG", "Newton"]
MissionEnd = Literal["land", "rtl", "hold"]


def check_number(
    field: str, value: object, lo: float = -math.inf, hi: float = math.inf, *, open_lo: bool = False
) -> float:
    """Return ``value`` as a float if it is a finite number in range, else raise."""
    bracket = "(" if open_lo else "["
    allowed = f"a finite number in {bracket}{lo:g}, {hi:g}]"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigurationError(field, value, allowed)
    v = float(value)
    if not math.isfinite(v) or v < lo or v > hi or (open_lo and v == lo):
        raise ConfigurationError(field, value, allowed)
    return v


class Home(msgspec.Struct, frozen=True):
    """Where the vehicle starts (WGS84 degrees, metres above mean sea level).

    The default is PX4 SITL's home (``PX4_HOME_LAT/LON/ALT``), Zurich.
    """

    lat: float = 47.397742
    lon: float = 8.545594
    alt: float = 488.0

    def __post_init__(self) -> None:
        check_number("home.lat", self.lat, -89.0, 89.0)
        check_number("home.lon", self.lon, -180.0, 180.0)
        check_number("home.alt", self.alt, -500.0, 9000.0)


class Topics(msgspec.Struct, frozen=True):
    """Topic names of the simulator interface; remap them to insert injectors or bridges.

    The world publishes ``imu``, ``mag``, ``baro``, ``gps`` and ``truth`` and reads
    ``actuators``; the autopilot reads the four sensor topics and publishes ``actuators``.
    Giving the world and the autopilot different names lets a component sit in between
    (for example a GPS attack reading ``px4/gps`` and publishing ``px4/gps/attacked``).
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


class MuJoCo(msgspec.Struct, frozen=True, kw_only=True):
    """The physics world of the PX4 scenario (the paper's ``px4.Gazebo()``).

    ``timestep`` is MuJoCo's integration step, ``integrator``/``solver``/``iterations`` its
    solver options; the world publishes sensors every ``period`` (a multiple of the timestep:
    the lockstep rate, which is also the autopilot's control rate; 0 picks the multiple of
    the timestep nearest to 10 ms, i.e. 100 Hz at the default timestep).
    ``noise`` scales the sensor noise of the medium-fidelity models (0 gives ideal sensors);
    ``home`` places the vehicle; ``topics`` remaps sensor topics.
    """

    timestep: float = 0.002
    integrator: Integrator = "implicitfast"
    solver: Solver = "Newton"
    iterations: int = 50
    period: float = 0.0
    noise: float = 1.0
    home: Home = msgspec.field(default_factory=Home)
    topics: Topics = msgspec.field(default_factory=Topics)

    def __post_init__(self) -> None:
        check_number("timestep", self.timestep, 0.0001, 0.02)
        if self.integrator not in ("Euler", "RK4", "implicit", "implicitfast"):
            raise ConfigurationError(
                "integrator", self.integrator, "'Euler', 'RK4', 'implicit' or 'implicitfast'"
            )
        if self.solver not in ("PGS", "CG", "Newton"):
            raise ConfigurationError("solver", self.solver, "'PGS', 'CG' or 'Newton'")
        if (
            isinstance(self.iterations, bool)
            or not isinstance(self.iterations, int)
            or not (1 <= self.iterations <= 1000)
        ):
            raise ConfigurationError("iterations", self.iterations, "an integer in [1, 1000]")
        if self.period == 0.0:
            # Any timestep (a search may sample it) gets a lockstep period near 10 ms.
            substeps = max(1, round(0.01 / self.timestep))
            msgspec.structs.force_setattr(self, "period", round(self.timestep * substeps, 9))
        check_number("period", self.period, 0.0001, 0.02)
        ratio = self.period / self.timestep
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
            raise ConfigurationError(
                "period", self.period, f"a whole multiple of timestep={self.timestep:g}"
            )
        check_number("noise", self.noise, 0.0, 10.0)
        if not isinstance(self.home, Home):
            raise ConfigurationError("home", self.home, "a px4.Home")
        if not isinstance(self.topics, Topics):
            raise ConfigurationError("topics", self.topics, "a px4.Topics")

    @property
    def substeps(self) -> int:
        """MuJoCo steps per world period."""
        return max(1, round(self.period / self.timestep))


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


class Configuration(msgspec.Struct, frozen=True):
    """What the ground station is told to fly (the paper's ``px4.Configuration(mission)``).

    ``end``: after the last waypoint, ``"land"`` there, return and land (``"rtl"``) or hold
    position (``"hold"``). ``takeoff_alt`` defaults to the first waypoint's altitude.
    ``time_limit`` bounds the mission in simulated seconds: past it the result is incomplete.
    """

    mission: list[Waypoint]
    end: MissionEnd = "land"
    cruise_speed: float = 5.0
    acceptance_radius: float = 2.0
    takeoff_alt: float | None = None
    time_limit: float = 600.0

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


class Sample(msgspec.Struct, frozen=True, kw_only=True):
    """One trajectory sample as the ground station sees it, plus the world's ground truth.

    ``lat``/``lon`` (deg), ``alt`` (m above home) and ``x``/``y``/``z`` (local NED, m) are the
    autopilot's estimate; ``true_*`` are the world's truth (they differ when sensors lie).
    ``mode`` is PX4's mode name (``AUTO.MISSION``), ``current`` the MAVLink sequence number
    of the current mission item (0: takeoff, 1..n: the configured waypoints, then land/RTL).
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


class WaypointReached(msgspec.Struct, frozen=True, kw_only=True):
    """Waypoint ``index`` (into the configured mission) was reached at simulated ``time``."""

    index: int
    time: float


class MissionResult(msgspec.Struct, frozen=True, kw_only=True):
    """The reply to a Configuration: trajectory, reached waypoints, outcome.

    ``completed`` says whether the mission ran to its configured end (landed and disarmed,
    or holding at the last waypoint); ``reason`` says why not. ``messages`` holds the
    autopilot's STATUSTEXT messages.
    """

    trajectory: list[Sample]
    reached: list[WaypointReached]
    completed: bool
    reason: str
    start_time: float
    end_time: float
    landed: bool
    armed: bool
    messages: list[str] = msgspec.field(default_factory=list)

    @property
    def duration(self) -> float:
        """Simulated seconds the mission took."""
        return self.end_time - self.start_time
