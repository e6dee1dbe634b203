"""The public coordinate convention: north, east, up by name; NED only where MAVLink has it."""

from __future__ import annotations

import math

import pytest

import multicosim as mcs
from multicosim import px4
from multicosim.core.geo import (
    EastNorthUp,
    Home,
    LocalProjection,
    NorthEast,
    geodetic_to_local,
    local_to_geodetic,
)
from multicosim.mavlink.mission import FlightSample


def test_a_projection_names_north_and_east() -> None:
    home = Home()
    projection = LocalProjection(home.lat, home.lon)
    lat, lon = projection.reproject(30.0, -10.0)
    point = projection.project(lat, lon)
    assert isinstance(point, NorthEast)
    assert (point.north, point.east) == pytest.approx((30.0, -10.0))


def test_world_frame_helpers_take_and_give_names() -> None:
    home = Home()
    with pytest.raises(TypeError):
        local_to_geodetic(home, 1.0, 2.0, 3.0)  # type: ignore[call-arg]  # positional: refused
    back = geodetic_to_local(home, *local_to_geodetic(home, east=1.0, north=2.0, up=3.0))
    assert isinstance(back, EastNorthUp)
    assert (back.north, back.east, back.up) == pytest.approx((2.0, 1.0, 3.0))


def test_a_flight_sample_gives_north_east_up_beside_mavlinks_ned() -> None:
    sample = FlightSample(
        time=1.0,
        lat=47.0,
        lon=8.0,
        alt=25.0,
        x=30.0,
        y=-10.0,
        z=-25.0,
        vx=0.0,
        vy=0.0,
        vz=0.0,
        roll=0.0,
        pitch=0.0,
        yaw=0.0,
        mode="AUTO.MISSION",
        armed=True,
        current=1,
        true_lat=47.0,
        true_lon=8.0,
        true_alt=25.0,
    )
    assert (sample.north, sample.east, sample.up) == (30.0, -10.0, 25.0)


def test_a_waypoint_is_placed_north_and_east_of_home_as_obstacles_are() -> None:
    home = px4.Home(lat=-33.9, lon=151.2, alt=20.0)
    waypoint = px4.Waypoint.local(north=30.0, east=-12.5, alt=10.0, home=home)
    north, east = LocalProjection(home.lat, home.lon).project(waypoint.lat, waypoint.lon)
    assert north == pytest.approx(30.0)
    assert east == pytest.approx(-12.5)
    assert waypoint.alt == 10.0
    # Without a home, PX4's default: the world's own.
    assert px4.Waypoint.local(0.0, 0.0, 5.0) == px4.Waypoint(px4.Home().lat, px4.Home().lon, 5.0)
    with pytest.raises(mcs.ConfigurationError, match="north"):
        px4.Waypoint.local(north=math.nan, east=0.0, alt=10.0)
