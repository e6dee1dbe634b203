"""Hypothesis strategies for encounters: two aircraft whose planned paths meet as asked.

An encounter is drawn by what a test cares about, its kind, the closest approach and the time
to it, and built from those: so every generated encounter is one by construction, not a pair of
random missions that mostly never meet. The ownship ``alpha`` flies north; the intruder
``bravo`` flies its own leg; both legs start together (each vehicle climbs first, where it
stands) and last twice the time to the closest approach:

```python
from hypothesis import given
from multicosim.fleet import strategies as fleetst

@given(fleetst.encounters(kinds=("crossing",), closest=(0.0, 10.0)))
def test_separation(encounter):
    with fleet.Fleet(encounter.vehicles(), fidelity="low").start() as simulation:
        result = simulation.fly(encounter.missions())
```

Kinds (the geometry of the planned legs at constant speed, as ICAO's and RTCA's encounter
models name them): ``head-on`` (tracks 180 degrees apart), ``crossing`` (30 to 150 degrees),
``overtaking`` (one track, the intruder faster, from behind), ``vertical`` (the intruder
climbs or descends through the ownship's altitude, crossing its track at an angle).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

from ..core.deps import require
from ..core.errors import ConfigurationError
from ..core.geo import LocalProjection
from ..mavlink.mission import Configuration, Home, Waypoint
from ..physics.fleet import Pose
from .scenario import PX4Vehicle

require("hypothesis", "hypothesis")
from hypothesis import strategies as st  # noqa: E402 - after the dependency check, which names the extra

from ..search.strategies import Range, check_range  # noqa: E402

__all__ = ["KINDS", "EncounterKind", "EncounterPlan", "encounters"]

EncounterKind = Literal["head-on", "crossing", "overtaking", "vertical"]
KINDS: tuple[EncounterKind, ...] = ("head-on", "crossing", "overtaking", "vertical")
"""Every kind of encounter [`encounters`][multicosim.fleet.strategies.encounters] draws."""

OWNSHIP, INTRUDER = "alpha", "bravo"


@dataclasses.dataclass(frozen=True)
class EncounterPlan:
    """Two planned legs at constant speed that come closest ``closest`` m apart (3-D, between
    the vehicles' centres) ``time`` s after they start.

    ``angle`` is the intruder's track in degrees clockwise from the ownship's (north);
    ``vertical`` the intruder's height above the ownship at the closest approach (for
    ``vertical`` encounters, which pass the ownship's altitude there, its climb over its path);
    ``speed`` and ``intruder_speed`` in m/s; ``altitude`` the ownship's, above home.
    """

    kind: EncounterKind
    closest: float
    time: float
    angle: float
    speed: float
    intruder_speed: float
    altitude: float = 15.0
    vertical: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigurationError("kind", self.kind, f"one of {', '.join(KINDS)}")
        if self.closest < abs(self.vertical) and self.kind != "vertical":
            raise ConfigurationError(
                "closest", self.closest, f"at least the vertical offset ({abs(self.vertical):g} m)"
            )
        if self.relative_speed < 0.5:
            raise ConfigurationError(
                "intruder_speed", self.intruder_speed, "tracks that close at 0.5 m/s or more"
            )

    @property
    def relative_speed(self) -> float:
        """How fast the intruder moves relative to the ownship, horizontally (m/s)."""
        return math.hypot(*self._relative())

    def _relative(self) -> tuple[float, float]:
        a = math.radians(self.angle)
        return (
            self.intruder_speed * math.cos(a) - self.speed,
            self.intruder_speed * math.sin(a),
        )

    def paths(self) -> dict[str, list[tuple[float, float, float]]]:
        """Each vehicle's planned path: points (north, east, up) in metres, flown at constant
        speed, the first at the start, the last ``2 * time`` s later, evenly spaced in time."""
        t = self.time
        own = [(-self.speed * t, 0.0, self.altitude), (self.speed * t, 0.0, self.altitude)]
        # At the closest approach the intruder is off the ownship by the miss vector:
        # horizontally across the relative track (so that the relative motion is closest
        # there), vertically by ``vertical``.
        wn, we = self._relative()
        w = math.hypot(wn, we)
        vertical = self.kind == "vertical"
        miss = self.closest if vertical else math.sqrt(max(self.closest**2 - self.vertical**2, 0))
        cn, ce = -we / w * miss, wn / w * miss
        a = math.radians(self.angle)
        vn, ve = self.intruder_speed * math.cos(a), self.intruder_speed * math.sin(a)
        if vertical:
            # Through the ownship's level at the closest approach: a waypoint there, since an
            # autopilot changes altitude at its own climb rate, not evenly along a leg.
            half = self.vertical / 2
            intruder = [
                (cn - vn * t, ce - ve * t, self.altitude - half),
                (cn, ce, self.altitude),
                (cn + vn * t, ce + ve * t, self.altitude + half),
            ]
        else:
            up = self.altitude + self.vertical
            intruder = [(cn - vn * t, ce - ve * t, up), (cn + vn * t, ce + ve * t, up)]
        return {OWNSHIP: own, INTRUDER: intruder}

    def separation(self, t: float) -> float:
        """The planned distance between the two centres ``t`` s after the legs start (m)."""
        where = []
        for points in self.paths().values():
            f = min(max(t / (2 * self.time), 0.0), 1.0) * (len(points) - 1)
            i = min(int(f), len(points) - 2)
            p, q = points[i], points[i + 1]
            where.append([a + (b - a) * (f - i) for a, b in zip(p, q, strict=True)])
        return math.dist(where[0], where[1])

    def vehicles(self) -> dict[str, PX4Vehicle]:
        """The two vehicles (the built-in autopilot), each standing where its path starts."""
        return {
            name: PX4Vehicle(start=Pose(north=points[0][0], east=points[0][1]))
            for name, points in self.paths().items()
        }

    def missions(
        self, home: Home | None = None, time_limit: float | None = None
    ) -> dict[str, Configuration]:
        """Each vehicle's mission: climb where it stands, fly its path at its speed, land.

        Both climb to the lowest height of their paths first; a path that starts higher
        climbs the rest on its way (so the first metres of its path are flown climbing).
        """
        home = home or Home()
        projection = LocalProjection(home.lat, home.lon)
        limit = time_limit if time_limit is not None else 2 * self.time + 60.0
        speeds = {OWNSHIP: self.speed, INTRUDER: self.intruder_speed}
        paths = self.paths()
        # Both climb to one height where they stand, the lowest of their paths: equal climbs
        # start their paths together (a vehicle's climb takes its own time before its path).
        takeoff = min(p[2] for points in paths.values() for p in points)
        missions = {}
        for name, points in paths.items():
            waypoints = [
                Waypoint(*projection.reproject(north, east), up) for north, east, up in points[1:]
            ]
            missions[name] = Configuration(
                waypoints, cruise_speed=speeds[name], takeoff_alt=takeoff, time_limit=limit
            )
        return missions


def encounters(
    kinds: tuple[EncounterKind, ...] = KINDS,
    *,
    closest: Range = (0.0, 30.0),
    time: Range = (10.0, 30.0),
    speed: Range = (3.0, 8.0),
    altitude: Range = (10.0, 30.0),
    vertical: Range = (0.0, 0.0),
) -> st.SearchStrategy[EncounterPlan]:
    """Encounters of ``kinds`` whose planned legs come ``closest`` m apart after ``time`` s.

    ``speed`` bounds both vehicles' speeds (an overtaking intruder is at least 1 m/s faster);
    ``vertical`` the intruder's height above the ownship at the closest approach (a
    ``vertical`` encounter's climb over its leg, at least 5 m, up or down).
    """
    if not kinds or any(k not in KINDS for k in kinds):
        raise ConfigurationError("kinds", kinds, f"a tuple of {', '.join(KINDS)}")
    near, far = check_range("closest", closest, low=0.0, high=1000.0)
    soon, late = check_range("time", time, low=5.0, high=600.0, low_open=True)
    slow, fast = check_range("speed", speed, low=1.0, high=15.0)
    low, high = check_range("altitude", altitude, low=5.0, high=120.0)
    below, above = check_range("vertical", vertical, low=-100.0, high=100.0)
    if "overtaking" in kinds and fast - slow < 1.0:
        raise ConfigurationError(
            "speed", speed, "a range at least 1 m/s wide (an overtaking intruder is faster)"
        )

    @st.composite
    def draw(draw: st.DrawFn) -> EncounterPlan:
        kind = draw(st.sampled_from(kinds))
        own = draw(st.floats(slow, fast))
        dz = draw(st.floats(below, above))
        if kind == "head-on":
            angle, other = 180.0, draw(st.floats(slow, fast))
        elif kind == "overtaking":
            angle = 0.0
            own = min(own, fast - 1.0)
            other = draw(st.floats(own + 1.0, fast))
        else:  # crossing, vertical
            angle = draw(st.sampled_from((1.0, -1.0))) * draw(st.floats(30.0, 150.0))
            other = draw(st.floats(slow, fast))
        if kind == "vertical":
            dz = draw(st.sampled_from((1.0, -1.0))) * draw(st.floats(5.0, 20.0))
            miss = draw(st.floats(near, far))
        else:
            miss = draw(st.floats(max(near, abs(dz)), max(far, abs(dz))))
        return EncounterPlan(
            kind=kind,
            closest=miss,
            time=draw(st.floats(soon, late)),
            angle=angle,
            speed=own,
            intruder_speed=other,
            altitude=draw(st.floats(max(low, abs(dz) + 5.0), max(high, abs(dz) + 5.0))),
            vertical=dz,
        )

    return draw()
