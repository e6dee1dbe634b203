"""Hypothesis strategies for the PX4 scenario: waypoints, missions, world configurations.

Everything generated is valid by construction (inside the geofence around home, sensible
physics options), so a property test spends its examples on behaviour, not on input
validation::

    from hypothesis import given
    from multicosim.px4 import strategies as px4st

    @given(px4st.missions(max_waypoints=3))
    def test_mission(config): ...
"""

from __future__ import annotations

import math

from hypothesis import strategies as st

from ..geo import LocalProjection
from ._config import Configuration, Geofence, Home, MissionEnd, MuJoCo, Waypoint

__all__ = ["missions", "waypoints", "worlds"]


@st.composite
def waypoints(
    draw: st.DrawFn,
    home: Home | None = None,
    *,
    max_distance: float = 200.0,
    min_alt: float = 5.0,
    max_alt: float = 50.0,
    geofence: Geofence | None = None,
) -> Waypoint:
    """A waypoint within ``max_distance`` m of ``home`` (and inside ``geofence``)."""
    home = home or Home()
    fence = geofence or Geofence()
    radius = min(max_distance, fence.radius * 0.95)
    top = min(max_alt, fence.max_alt)
    # Uniform over the disc: sqrt of a uniform radius fraction.
    r = radius * math.sqrt(draw(st.floats(0.0, 1.0)))
    bearing = draw(st.floats(0.0, 2 * math.pi, exclude_max=True))
    lat, lon = LocalProjection(home.lat, home.lon).reproject(
        r * math.cos(bearing), r * math.sin(bearing)
    )
    alt = draw(st.floats(min(min_alt, top), top))
    return Waypoint(round(lat, 7), round(lon, 7), round(alt, 2))


@st.composite
def missions(
    draw: st.DrawFn,
    home: Home | None = None,
    *,
    min_waypoints: int = 1,
    max_waypoints: int = 4,
    max_distance: float = 200.0,
    min_alt: float = 5.0,
    max_alt: float = 50.0,
    geofence: Geofence | None = None,
    ends: tuple[MissionEnd, ...] = ("land", "rtl", "hold"),
    time_limit: float = 600.0,
) -> Configuration:
    """A mission Configuration with waypoints inside the geofence around ``home``."""
    wps = draw(
        st.lists(
            waypoints(
                home, max_distance=max_distance, min_alt=min_alt, max_alt=max_alt, geofence=geofence
            ),
            min_size=min_waypoints,
            max_size=max_waypoints,
        )
    )
    end = draw(st.sampled_from(ends))
    speed = draw(st.sampled_from((3.0, 5.0, 8.0)))
    return Configuration(wps, end=end, cruise_speed=speed, time_limit=time_limit)


@st.composite
def worlds(draw: st.DrawFn, home: Home | None = None) -> MuJoCo:
    """A MuJoCo world configuration: step, integrator, solver, iterations, noise."""
    timestep = draw(st.sampled_from((0.001, 0.002, 0.004)))
    substeps = draw(st.sampled_from((1, 2, 4)))
    period = timestep * substeps
    if period > 0.01:
        period = timestep * 2
    return MuJoCo(
        timestep=timestep,
        period=round(period, 6),
        integrator=draw(st.sampled_from(("Euler", "RK4", "implicit", "implicitfast"))),
        solver=draw(st.sampled_from(("PGS", "CG", "Newton"))),
        iterations=draw(st.integers(1, 100)),
        noise=draw(st.sampled_from((0.0, 0.5, 1.0))),
        home=home or Home(),
    )
