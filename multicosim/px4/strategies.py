"""Hypothesis strategies for the PX4 scenario: waypoints, missions, world configurations.

Everything generated is valid by construction (inside the geofence around home, sensible
physics options), so a property test spends its examples on behaviour, not on input
validation. Ranges are ``(low, high)`` tuples, as in
[`multicosim.search.strategies`][multicosim.search.strategies]:

```python
from hypothesis import given
from multicosim.px4 import strategies as px4st

@given(px4st.missions(count=(1, 3), altitude=(10.0, 30.0)))
def test_mission(config): ...
```
"""

from __future__ import annotations

import math

from ..core.deps import require
from ..core.geo import LocalProjection
from ..mavlink.mission import Configuration, Geofence, Home, MissionEnd, Waypoint
from ..physics.config import WorldConfig

require("hypothesis", "hypothesis")
from hypothesis import strategies as st  # noqa: E402 - after the dependency check, which names the extra

from ..search.strategies import Range, check_range  # noqa: E402

__all__ = ["missions", "waypoints", "worlds"]


def waypoints(
    home: Home | None = None,
    *,
    distance: Range = (0.0, 200.0),
    altitude: Range = (5.0, 50.0),
    geofence: Geofence | None = None,
) -> st.SearchStrategy[Waypoint]:
    """A waypoint ``distance`` m from ``home`` at ``altitude`` m, inside ``geofence``."""
    home = home or Home()
    fence = geofence or Geofence()
    near, far = check_range("distance", distance, low=0.0, high=1e5)
    low, high = check_range("altitude", altitude, low=0.0, high=10_000.0)
    far = min(far, fence.radius * 0.95)
    near = min(near, far)
    top = min(high, fence.max_alt)
    projection = LocalProjection(home.lat, home.lon)

    @st.composite
    def draw_waypoint(draw: st.DrawFn) -> Waypoint:
        # Uniform over the ring: the square root of a uniform fraction of its area.
        area = draw(st.floats(0.0, 1.0))
        r = math.sqrt(near**2 + area * (far**2 - near**2))
        bearing = draw(st.floats(0.0, 2 * math.pi, exclude_max=True))
        lat, lon = projection.reproject(r * math.cos(bearing), r * math.sin(bearing))
        alt = draw(st.floats(min(low, top), top))
        return Waypoint(round(lat, 7), round(lon, 7), round(alt, 2))

    return draw_waypoint()


def missions(
    home: Home | None = None,
    *,
    count: tuple[int, int] = (1, 4),
    distance: Range = (0.0, 200.0),
    altitude: Range = (5.0, 50.0),
    geofence: Geofence | None = None,
    ends: tuple[MissionEnd, ...] = ("land", "rtl", "hold"),
    time_limit: float = 600.0,
) -> st.SearchStrategy[Configuration]:
    """A mission Configuration of ``count`` waypoints inside the geofence around ``home``."""
    fewest, most = check_range("count", count, low=1, high=100, integer=True)
    points = waypoints(home, distance=distance, altitude=altitude, geofence=geofence)

    @st.composite
    def draw_mission(draw: st.DrawFn) -> Configuration:
        wps = draw(st.lists(points, min_size=int(fewest), max_size=int(most)))
        end = draw(st.sampled_from(ends))
        speed = draw(st.sampled_from((3.0, 5.0, 8.0)))
        return Configuration(wps, end=end, cruise_speed=speed, time_limit=time_limit)

    return draw_mission()


@st.composite
def worlds(draw: st.DrawFn, home: Home | None = None) -> WorldConfig:
    """A MuJoCo world configuration: step, integrator, solver, iterations, noise."""
    timestep = draw(st.sampled_from((0.001, 0.002, 0.004)))
    substeps = draw(st.sampled_from((1, 2, 4)))
    period = timestep * substeps
    if period > 0.01:
        period = timestep * 2
    return WorldConfig(
        timestep=timestep,
        period=round(period, 6),
        integrator=draw(st.sampled_from(("Euler", "RK4", "implicit", "implicitfast"))),
        solver=draw(st.sampled_from(("PGS", "CG", "Newton"))),
        iterations=draw(st.integers(1, 100)),
        noise=draw(st.sampled_from((0.0, 0.5, 1.0))),
        home=home or Home(),
    )
