"""Obstacle and wind strategies: valid by construction, within their bounds, simplest first."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, find, given, settings

import multicosim as mcs
import multicosim.px4 as px4
import multicosim.search.strategies as mst
from multicosim.core.geo import LocalProjection
from multicosim.physics import Obstacle, Wind, WorldConfig
from multicosim.physics.obstacles import HOME_MARGIN, placed

HOME = px4.Home()


@given(mst.obstacles(count=(2, 5), north=(-40.0, 40.0), east=(-40.0, 40.0), size=(1.0, 8.0)))
@settings(suppress_health_check=[HealthCheck.filter_too_much])
def test_generated_obstacles_are_a_valid_world_within_their_bounds(
    obstacles: tuple[Obstacle, ...],
) -> None:
    assert 2 <= len(obstacles) <= 5
    world = WorldConfig(obstacles=obstacles)  # no overlap, none over home: it validates
    for o in placed(world.obstacles, world.home):
        assert -40.0 <= o.north <= 40.0
        assert -40.0 <= o.east <= 40.0
        assert 2.0 <= o.height <= 40.0
        sides = (2 * o.radius,) if o.radius else (2 * o.half_length, 2 * o.half_width)
        assert all(1.0 <= s <= 8.0 for s in sides)
        assert o.footprint_distance(0.0, 0.0) >= HOME_MARGIN


def test_obstacles_shrink_to_none_and_wind_to_still_air() -> None:
    assert find(mst.obstacles(), lambda _: True) == ()
    assert find(mst.winds(), lambda _: True) == Wind(speed=0.0, direction=0.0)
    # Fewer obstacles first (how far each one's sizes shrink is Hypothesis's business).
    smallest = find(mst.obstacles(count=(1, 3)), lambda o: len(o) >= 1)
    assert len(smallest) == 1


@given(mst.winds(speed=(2.0, 12.0), turbulence=(0.0, 5.0), gusts=(1, 3)))
def test_generated_winds_stay_within_their_bounds(wind: Wind) -> None:
    assert 2.0 <= wind.speed <= 12.0
    assert 0.0 <= wind.turbulence <= 5.0
    assert 1 <= len(wind.gusts) <= 3
    assert 0.0 <= wind.direction < 360.0


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: mst.obstacles(count=(3, 1)), "count"),
        (lambda: mst.obstacles(size=(0.0, 5.0)), "size"),
        (lambda: mst.obstacles(kinds=("sphere",)), "kinds"),
        (lambda: mst.winds(speed=(-1.0, 5.0)), "speed"),
        (lambda: mst.winds(turbulence=(0.0, math.inf)), "turbulence"),
    ],
)
def test_bad_bounds_name_the_argument(make: object, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        make()  # type: ignore[operator]
    assert info.value.field == field


PROJ = LocalProjection(HOME.lat, HOME.lon)


@given(
    obstacles=mst.obstacles(count=(1, 3), north=(10.0, 60.0), east=(-30.0, 30.0)),
    wind=mst.winds(speed=(0.0, 6.0), turbulence=(0.0, 2.0), gusts=(0, 1)),
)
@settings(max_examples=5, deadline=None, suppress_health_check=list(HealthCheck))
def test_a_flight_among_generated_obstacles_reports_a_collision_or_a_clearance(
    obstacles: tuple[Obstacle, ...], wind: Wind
) -> None:
    world = px4.WorldConfig(obstacles=obstacles, wind=wind)
    lat, lon = PROJ.reproject(70.0, 0.0)
    with px4.PX4(world, fidelity="low").start() as sim:
        result = sim.firmware.send(px4.Configuration([px4.Waypoint(lat, lon, 10.0)]))
    # Whatever it met: a collision ends the mission, else its clearance stayed positive.
    if result.collision is not None:
        assert not result.completed
        assert 0 <= result.collision.obstacle < len(obstacles)
        assert result.min_clearance <= 0.05
    else:
        assert result.completed, result.reason
        assert 0.0 < result.min_clearance < math.inf
