"""Obstacles in the world: boxes and cylinders standing on the ground, and how close a body is.

An obstacle is placed by its centre on the ground, in local metres from home (``north=``,
``east=``) or in WGS84 degrees (``lat=``, ``lon=``); a box's ``length`` lies along its ``yaw``
(degrees clockwise from north), its ``width`` across. The same shapes serve every fidelity:
MuJoCo collision geometry at medium and high (``multicosim.physics.world`` adds them to
the model), the analytic distances here at low.

``ClearanceMonitor`` measures a vehicle against the obstacles: the 3-D distance from its
body (a sphere) to the nearest obstacle, the 2-D distance from its footprint (a disc) to the
nearest obstacle's footprint, as PX4's community test-generation benchmark measures it, and
the first collision. No MuJoCo import here: the low-fidelity world and the configuration use it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import msgspec

from ..core.errors import ConfigurationError, check_number
from ..core.geo import LocalProjection

__all__ = [
    "HOME_MARGIN",
    "Box",
    "ClearanceMonitor",
    "Cylinder",
    "Obstacle",
    "Proximity",
    "check_obstacles",
    "placed",
]

HOME_MARGIN = 1.0
"""No obstacle's footprint may come within this many metres of home (the vehicle stands there)."""

MAX_SIZE = 10_000.0


def _positive(field: str, value: object) -> float:
    return check_number(field, value, 0.0, MAX_SIZE, open_lo=True)


def _check_place(kind: str, shape: _Standing) -> None:
    local = shape.north is not None and shape.east is not None
    geodetic = shape.lat is not None and shape.lon is not None
    given = sum(v is not None for v in (shape.north, shape.east, shape.lat, shape.lon))
    if local == geodetic or given != 2:
        raise ConfigurationError(
            f"{kind}.north",
            (shape.north, shape.east, shape.lat, shape.lon),
            "a centre as north= and east= (m from home), or as lat= and lon= (degrees)",
        )
    for field in ("north", "east"):
        value = getattr(shape, field)
        if value is not None:
            check_number(f"{kind}.{field}", value)
    if shape.lat is not None:
        check_number(f"{kind}.lat", shape.lat, -90.0, 90.0)
    if shape.lon is not None:
        check_number(f"{kind}.lon", shape.lon, -180.0, 180.0)
    if not isinstance(shape.name, str):
        raise ConfigurationError(f"{kind}.name", shape.name, "a string")


class _Standing(msgspec.Struct, frozen=True, kw_only=True):
    """Where an obstacle stands: the centre of its footprint, in metres or degrees."""

    north: float | None = None
    east: float | None = None
    lat: float | None = None
    lon: float | None = None
    name: str = ""


class Box(_Standing, frozen=True, kw_only=True, tag="box"):
    """A box standing on the ground: ``length`` along ``yaw``, ``width`` across, ``height`` (m).

    The centre of its footprint is ``north=``/``east=`` (m from home) or ``lat=``/``lon=``;
    ``yaw`` is degrees clockwise from north; ``name`` labels it in results and traces.
    """

    length: float
    width: float
    height: float
    yaw: float = 0.0

    def __post_init__(self) -> None:
        for field in ("length", "width", "height"):
            _positive(f"box.{field}", getattr(self, field))
        check_number("box.yaw", self.yaw)
        _check_place("box", self)


class Cylinder(_Standing, frozen=True, kw_only=True, tag="cylinder"):
    """A vertical cylinder standing on the ground: ``radius`` and ``height`` (m).

    The centre of its footprint is ``north=``/``east=`` (m from home) or ``lat=``/``lon=``.
    """

    radius: float
    height: float

    def __post_init__(self) -> None:
        for field in ("radius", "height"):
            _positive(f"cylinder.{field}", getattr(self, field))
        _check_place("cylinder", self)


Obstacle = Box | Cylinder
"""An obstacle of the world's configuration."""


class Placed(NamedTuple):
    """Obstacle ``number`` (its index in the configuration) resolved to local metres: centre
    ``north``/``east``, footprint, height.

    A box has half-sizes ``half_length``/``half_width`` along its axis at ``yaw`` (radians
    clockwise from north); a cylinder has ``radius`` (its half-sizes are 0).
    """

    number: int
    name: str
    north: float
    east: float
    height: float
    yaw: float = 0.0
    half_length: float = 0.0
    half_width: float = 0.0
    radius: float = 0.0

    @property
    def label(self) -> str:
        """Its name, else ``obstacle <number>``."""
        return self.name or f"obstacle {self.number}"

    def footprint_distance(self, north: float, east: float) -> float:
        """Signed horizontal distance (m) from a point to the footprint (< 0 inside)."""
        dn, de = north - self.north, east - self.east
        if self.radius:
            return math.hypot(dn, de) - self.radius
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return _box_footprint(dn, de, c, s, self.half_length, self.half_width)

    def distance(self, north: float, east: float, up: float) -> float:
        """Signed 3-D distance (m) from a point to the solid (< 0 inside)."""
        return _solid(self.footprint_distance(north, east), max(-up, up - self.height))

    def corners(self) -> list[tuple[float, float]]:
        """The footprint's outline as (north, east) points (a polygon for a cylinder)."""
        if self.radius:
            return [
                (
                    self.north + self.radius * math.cos(2 * math.pi * k / 32),
                    self.east + self.radius * math.sin(2 * math.pi * k / 32),
                )
                for k in range(32)
            ]
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return [
            (
                self.north + a * self.half_length * c - b * self.half_width * s,
                self.east + a * self.half_length * s + b * self.half_width * c,
            )
            for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1))
        ]


def placed(obstacles: Sequence[Obstacle], home: tuple[float, float, float]) -> list[Placed]:
    """The obstacles in local metres around ``home`` (lat/lon centres projected)."""
    projection = LocalProjection.at(home)
    out = []
    for i, o in enumerate(obstacles):
        if o.north is not None and o.east is not None:
            north, east = o.north, o.east
        else:
            assert o.lat is not None
            assert o.lon is not None
            north, east = projection.project(o.lat, o.lon)
        if isinstance(o, Box):
            out.append(
                Placed(
                    i,
                    o.name,
                    north,
                    east,
                    o.height,
                    yaw=math.radians(o.yaw),
                    half_length=o.length / 2,
                    half_width=o.width / 2,
                )
            )
        else:
            out.append(Placed(i, o.name, north, east, o.height, radius=o.radius))
    return out


def _box_footprint(
    dn: float, de: float, c: float, s: float, half_length: float, half_width: float
) -> float:
    """Signed horizontal distance to a box's footprint from a point ``dn``/``de`` (m) off its
    centre; ``c``, ``s``: the cosine and sine of its yaw."""
    along = abs(dn * c + de * s) - half_length
    across = abs(-dn * s + de * c) - half_width
    if along <= 0.0 and across <= 0.0:
        return max(along, across)
    return math.hypot(max(along, 0.0), max(across, 0.0))


def _solid(flat: float, vertical: float) -> float:
    """The signed distance to a solid from the horizontal and vertical distances to it."""
    if flat <= 0.0 and vertical <= 0.0:
        return max(flat, vertical)
    return math.hypot(max(flat, 0.0), max(vertical, 0.0))


def _axes(p: Placed) -> list[tuple[float, float]]:
    c, s = math.cos(p.yaw), math.sin(p.yaw)
    return [(c, s), (-s, c)]


def _overlap(a: Placed, b: Placed) -> bool:
    if a.radius and b.radius:
        return math.hypot(a.north - b.north, a.east - b.east) < a.radius + b.radius
    if a.radius or b.radius:
        circle, box = (a, b) if a.radius else (b, a)
        return box.footprint_distance(circle.north, circle.east) < circle.radius
    # Two rectangles: separated if their projections on one of the four axes are disjoint.
    pa, pb = a.corners(), b.corners()
    for axis in _axes(a) + _axes(b):
        ra = [n * axis[0] + e * axis[1] for n, e in pa]
        rb = [n * axis[0] + e * axis[1] for n, e in pb]
        if max(ra) <= min(rb) or max(rb) <= min(ra):
            return False
    return True


def check_obstacles(obstacles: object, home: tuple[float, float, float]) -> tuple[Obstacle, ...]:
    """The obstacles as a tuple; ConfigurationError for overlaps or one over home."""
    if not isinstance(obstacles, list | tuple):
        raise ConfigurationError("obstacles", obstacles, "a sequence of Box or Cylinder")
    for i, o in enumerate(obstacles):
        if not isinstance(o, Box | Cylinder):
            raise ConfigurationError(f"obstacles[{i}]", o, "a physics.Box or physics.Cylinder")
    local = placed(obstacles, home)
    for p in local:
        gap = p.footprint_distance(0.0, 0.0)
        if gap < HOME_MARGIN:
            raise ConfigurationError(
                f"obstacles[{p.number}]",
                obstacles[p.number],
                f"an obstacle at least {HOME_MARGIN:g} m from home (its footprint is "
                f"{max(gap, 0.0):.2f} m away)",
            )
        for q in local[: p.number]:
            if _overlap(p, q):
                raise ConfigurationError(
                    f"obstacles[{p.number}]",
                    obstacles[p.number],
                    f"an obstacle that does not overlap obstacles[{q.number}]",
                )
    return tuple(obstacles)


class Proximity(NamedTuple):
    """How close the vehicle is to the obstacles, and its first collision.

    ``clearance``: 3-D distance (m) from the vehicle's body to the nearest obstacle (< 0:
    inside it); ``footprint``: 2-D distance from its footprint to the nearest obstacle's
    footprint; both infinite without obstacles. ``contact``: the obstacle it touches now
    (-1: none). ``hit``: the first obstacle it ever touched (-1: none), at ``hit_time``
    (simulated s) with speed ``hit_speed`` (m/s).
    """

    clearance: float = math.inf
    footprint: float = math.inf
    contact: int = -1
    hit: int = -1
    hit_time: float = 0.0
    hit_speed: float = 0.0


NO_OBSTACLES = Proximity()


_Shape = tuple[int, float, float, float, float, float, float, float, float, float]
_REORDER = 1.0  # m: how far the body moves before the obstacles are put in order again
_SLACK = 1e-6  # m: far above rounding, so a bound skips no obstacle at the nearest distance


def _measure(shape: _Shape, north: float, east: float, up: float) -> tuple[float, float]:
    """(solid, footprint) signed distances from a point to a ``ClearanceMonitor`` shape:
    ``Placed.distance`` and ``Placed.footprint_distance``, from worked-out numbers."""
    _, n0, e0, height, c, s, half_length, half_width, radius, _ = shape
    dn, de = north - n0, east - e0
    if radius:
        flat = math.hypot(dn, de) - radius
    else:
        flat = _box_footprint(dn, de, c, s, half_length, half_width)
    return _solid(flat, max(-up, up - height)), flat


class ClearanceMonitor:
    """Measures a body (a sphere of ``radius`` m) against the obstacles, latching the first hit."""

    def __init__(self, obstacles: Sequence[Placed], radius: float) -> None:
        self.obstacles = list(obstacles)
        self.radius = radius
        self.proximity = NO_OBSTACLES
        # Per obstacle, what a measurement needs, worked out once: number, centre, height,
        # the box's axis (cos, sin of its yaw) and half-sizes or the cylinder's radius, and
        # the radius of the footprint's enclosing circle.
        self._shapes: list[_Shape] = [
            (
                p.number,
                p.north,
                p.east,
                p.height,
                math.cos(p.yaw),
                math.sin(p.yaw),
                p.half_length,
                p.half_width,
                p.radius,
                p.radius or math.hypot(p.half_length, p.half_width),
            )
            for p in self.obstacles
        ]
        # The obstacles nearest first as seen from a reference point, with each one's lower
        # bound there (the distance to its enclosing circle, never above its footprint's or
        # its solid's). Within ``moved`` m of that point a bound drops by at most ``moved``:
        # once one exceeds the nearest distance found, so does every later one.
        self._ref = (math.inf, math.inf)
        self._order: list[tuple[float, _Shape]] = []

    def update(
        self,
        time: float,
        north: float,
        east: float,
        up: float,
        speed: float,
        contact: int | None = None,
    ) -> Proximity:
        """Measure the body centred at ``north``/``east``/``up`` (m); ``contact`` from physics.

        Without ``contact`` (the analytic model) the body touches the nearest obstacle when
        its clearance is not positive.
        """
        if not self._shapes:
            return self.proximity
        ref_north, ref_east = self._ref
        moved = math.hypot(north - ref_north, east - ref_east)
        if moved > _REORDER:
            self._reorder(north, east)
            moved = 0.0
        best, flat, nearest = math.inf, math.inf, -1
        for bound, shape in self._order:
            if bound - moved > best + _SLACK:
                break
            d, f = _measure(shape, north, east, up)
            if f < flat:
                flat = f
            # The same as measuring in order of number: the first obstacle at the minimum.
            if d < best or (d == best and shape[0] < nearest):
                best, nearest = d, shape[0]
        r = self.radius
        best -= r
        flat -= r
        touching = (nearest if best <= 0.0 else -1) if contact is None else contact
        old = self.proximity
        hit, hit_time, hit_speed = old.hit, old.hit_time, old.hit_speed
        if hit < 0 and touching >= 0:
            hit, hit_time, hit_speed = touching, time, speed
        self.proximity = Proximity(best, flat, touching, hit, hit_time, hit_speed)
        return self.proximity

    def _reorder(self, north: float, east: float) -> None:
        self._ref = (north, east)
        self._order = sorted(
            ((math.hypot(north - s[1], east - s[2]) - s[9], s) for s in self._shapes),
            key=lambda bound_shape: bound_shape[0],
        )
