"""Obstacles and wind in the world configuration: validation, geometry, Dryden statistics."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import multicosim as mcs
from multicosim.core.geo import LocalProjection
from multicosim.physics import LIGHT, MODERATE, Box, Cylinder, Gust, Wind, WorldConfig
from multicosim.physics.obstacles import ClearanceMonitor, placed
from multicosim.physics.wind import (
    AIR_DENSITY,
    Body,
    DrydenTurbulence,
    WindField,
    drag_force,
    dryden_scales,
    wind_generator,
)

HOME = WorldConfig().home


def test_a_box_placed_by_latitude_is_the_box_placed_in_metres() -> None:
    lat, lon = LocalProjection.at(HOME).reproject(30.0, -12.0)
    by_degrees = placed([Box(length=4, width=2, height=5, lat=lat, lon=lon)], HOME)[0]
    assert by_degrees.north == pytest.approx(30.0, abs=1e-6)
    assert by_degrees.east == pytest.approx(-12.0, abs=1e-6)


def test_distances_to_a_yawed_box_and_a_cylinder() -> None:
    # 10 m long along north-east (yaw 45), 2 m wide, 6 m high, centred 20 m north.
    box, cyl = placed(
        [
            Box(length=10, width=2, height=6, north=20, east=0, yaw=45),
            Cylinder(radius=3, height=4, north=0, east=-20),
        ],
        HOME,
    )
    # Along the box's axis, 1 m beyond its end; across it, 2 m beside it.
    axis = (math.cos(math.radians(45)), math.sin(math.radians(45)))
    assert box.footprint_distance(20 + 6 * axis[0], 6 * axis[1]) == pytest.approx(1.0)
    assert box.footprint_distance(20 - 3 * axis[1], 3 * axis[0]) == pytest.approx(2.0)
    assert box.footprint_distance(20, 0) == pytest.approx(-1.0)  # centre: 1 m from the sides
    # Above its top: the vertical gap; diagonally off an edge: Pythagoras.
    assert box.distance(20, 0, 9) == pytest.approx(3.0)
    assert box.distance(20 - 4 * axis[1], 4 * axis[0], 10) == pytest.approx(5.0)
    assert cyl.footprint_distance(0, -10) == pytest.approx(7.0)
    assert cyl.distance(0, -20, 2) == pytest.approx(-2.0)  # inside: to the top and bottom


def test_clearance_monitor_latches_the_first_hit() -> None:
    monitor = ClearanceMonitor(placed([Cylinder(radius=1, height=10, north=10, east=0)], HOME), 0.5)
    far = monitor.update(1.0, 0.0, 0.0, 5.0, 2.0)
    assert far.clearance == pytest.approx(8.5)
    assert far.footprint == pytest.approx(8.5)
    assert far.hit == -1
    touching = monitor.update(2.0, 8.6, 0.0, 5.0, 3.0)
    assert (touching.contact, touching.hit, touching.hit_time, touching.hit_speed) == (
        0,
        0,
        2.0,
        3.0,
    )
    later = monitor.update(3.0, 0.0, 0.0, 5.0, 1.0)
    assert (later.contact, later.hit, later.hit_time) == (-1, 0, 2.0)


# A mirror-symmetric layout: on the axis east = 0 two obstacles are equally near (and
# at 10 m north, both touch the body).
LAYOUT = placed(
    [
        Cylinder(radius=2, height=10, north=10, east=-2.25),
        Cylinder(radius=2, height=10, north=10, east=2.25),
        Box(length=6, width=3, height=4, north=-12, east=-8, yaw=30),
        Box(length=6, width=3, height=4, north=-12, east=8, yaw=-30),
        Box(length=20, width=1, height=15, north=0, east=25, yaw=90),
    ],
    HOME,
)
POINT = st.tuples(
    st.sampled_from([-30.0, -12.0, -6.0, -0.5, 0.0, 0.5, 6.0, 10.0, 12.0, 30.0])
    | st.floats(-40, 40),
    st.sampled_from([-8.0, -6.0, 0.0, 6.0, 8.0]) | st.floats(-40, 40),
    st.sampled_from([0.0, 4.0, 10.0]) | st.floats(0, 20),
)


@given(st.lists(POINT, min_size=1, max_size=40))
def test_clearance_monitor_measures_the_nearest_of_all_obstacles(
    walk: list[tuple[float, float, float]],
) -> None:
    # However the body wanders (small steps or jumps), the monitor finds what measuring
    # every obstacle finds: the smallest distances, the first obstacle at the nearest.
    monitor = ClearanceMonitor(LAYOUT, 0.5)
    for t, (north, east, up) in enumerate(walk):
        got = monitor.update(float(t), north, east, up, 1.0)
        solids = [p.distance(north, east, up) for p in LAYOUT]
        nearest = min(solids)
        assert got.clearance == nearest - 0.5
        assert got.footprint == min(p.footprint_distance(north, east) for p in LAYOUT) - 0.5
        assert got.contact == (solids.index(nearest) if nearest <= 0.5 else -1)


SQUARE = Box(length=4, width=4, height=5, north=10, east=0)
DIAMOND = Box(length=4, width=4, height=5, north=10, east=0, yaw=45)
POST = Cylinder(radius=2, height=3, north=20, east=0)


@pytest.mark.parametrize(
    ("obstacles", "field"),
    [
        ([SQUARE, Cylinder(radius=2, height=3, north=13, east=1)], "obstacles[1]"),
        # The diamond's east corner (2.83 m) reaches into a square whose side is 2.5 m east.
        ([DIAMOND, Box(length=4, width=4, height=5, north=10, east=4.5)], "obstacles[1]"),
        ([POST, Cylinder(radius=2, height=3, north=23, east=0)], "obstacles[1]"),
        ([Box(length=2, width=2, height=5, north=0, east=0)], "obstacles[0]"),
        ([Cylinder(radius=5, height=5, north=3, east=3)], "obstacles[0]"),
        ("box", "obstacles"),
    ],
)
def test_bad_obstacle_layouts_are_refused(obstacles: object, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        WorldConfig(obstacles=obstacles)  # type: ignore[arg-type]
    assert info.value.field == field


def test_two_boxes_side_by_side_do_not_overlap() -> None:
    config = WorldConfig(obstacles=(DIAMOND, Box(length=4, width=4, height=5, north=10, east=6)))
    assert len(config.obstacles) == 2


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: Box(length=math.nan, width=1, height=1, north=5, east=5), "box.length"),
        (lambda: Box(length=1, width=0, height=1, north=5, east=5), "box.width"),
        (lambda: Box(length=1, width=1, height=-2, north=5, east=5), "box.height"),
        (lambda: Box(length=1, width=1, height=1, north=5, east=5, yaw=math.inf), "box.yaw"),
        (lambda: Box(length=1, width=1, height=1, north=5), "box.north"),
        (lambda: Box(length=1, width=1, height=1, north=5, east=5, lat=47.0, lon=8.0), "box.north"),
        (lambda: Cylinder(radius=math.inf, height=1, north=5, east=5), "cylinder.radius"),
        (lambda: Cylinder(radius=1, height=1, lat=95.0, lon=8.0), "cylinder.lat"),
        (lambda: Wind(speed=math.nan), "wind.speed"),
        (lambda: Wind(speed=5, direction=math.inf), "wind.direction"),
        (lambda: Wind(turbulence=-1.0), "wind.turbulence"),
        (lambda: Gust(start=1, duration=0, speed=3), "gust.duration"),
    ],
)
def test_bad_sizes_and_winds_name_the_field(make: object, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        make()  # type: ignore[operator]
    assert info.value.field == field


def test_world_config_with_obstacles_and_wind_round_trips_through_json() -> None:
    config = WorldConfig(
        obstacles=(
            Box(length=4, width=2, height=5, north=10, east=3, yaw=30, name="shed"),
            Cylinder(radius=1, height=8, north=-10, east=3),
        ),
        wind=Wind(speed=5, direction=270, gusts=(Gust(start=3, duration=2, speed=4),)),
    )
    assert msgspec.json.decode(msgspec.json.encode(config), type=WorldConfig) == config


def test_steady_wind_blows_from_its_direction_and_a_gust_is_one_minus_cosine() -> None:
    gust = Gust(start=10.0, duration=4.0, speed=6.0, direction=0.0)
    field = WindField(Wind(speed=8.0, direction=90.0, gusts=(gust,)), 0.01, wind_generator(0))
    north, east, up = field.step(0.0, 10.0)
    assert (north, east, up) == pytest.approx((0.0, -8.0, 0.0), abs=1e-12)  # from the east
    # Half-way through the gust it peaks; it blows from the north (southwards).
    north, east, _ = field.step(12.0, 10.0)
    assert (north, east) == pytest.approx((-6.0, -8.0), abs=1e-12)


def test_drag_follows_the_air_relative_to_the_body() -> None:
    body = Body("vehicle", 0.4, 1.0, 0.06)
    fx, fy, fz = drag_force(body, (0.0, -8.0, 0.0), (0.0, 0.0, 0.0))
    assert (fx, fz) == (0.0, 0.0)
    assert fy == pytest.approx(-0.5 * AIR_DENSITY * 0.06 * 64)
    assert drag_force(body, (3.0, 0.0, 0.0), (3.0, 0.0, 0.0)) == (0.0, 0.0, 0.0)


def test_low_altitude_scales_are_mil_f_8785c() -> None:
    # At 100 ft with W20 = 30 kt: sigma_w = 3 kt, L_w = 100 ft, L_u = 100 / 0.2593^1.2 ft.
    scales = dryden_scales(100 * 0.3048, MODERATE)
    base = 0.177 + 0.000823 * 100
    assert scales.sigma_w == pytest.approx(0.1 * MODERATE)
    assert scales.sigma_u == pytest.approx(0.1 * MODERATE / base**0.4)
    assert scales.length_w == pytest.approx(100 * 0.3048)
    assert scales.length_u == pytest.approx(100 / base**1.2 * 0.3048)


@pytest.mark.parametrize("dt", [0.01, 0.1])
def test_dryden_standard_deviations_match_sigma(dt: float) -> None:
    altitude = 30.0
    turbulence = DrydenTurbulence(LIGHT, 10.0, dt, np.random.default_rng(7))
    samples = np.array([turbulence.step(altitude) for _ in range(200_000)])
    scales = dryden_scales(altitude, LIGHT)
    # Long correlation times (L/V of a few seconds): 200k steps hold hundreds of them.
    expected = (scales.sigma_u, scales.sigma_u, scales.sigma_w)
    assert samples.std(axis=0) == pytest.approx(expected, rel=0.1)
    assert np.abs(samples.mean(axis=0)) == pytest.approx((0, 0, 0), abs=0.25 * scales.sigma_u)
    # Correlated, not white: neighbouring samples are close.
    lag = np.corrcoef(samples[:-1, 0], samples[1:, 0])[0, 1]
    assert lag > math.exp(-10.0 * dt / scales.length_u) - 0.02


def test_a_seed_reproduces_the_turbulence_exactly() -> None:
    wind = Wind(speed=6.0, direction=45.0, turbulence=MODERATE)

    def series(seed: int) -> list[tuple[float, float, float]]:
        field = WindField(wind, 0.01, wind_generator(seed))
        return [field.step(i * 0.01, 20.0) for i in range(500)]

    assert series(3) == series(3)
    assert series(3) != series(4)
