"""The public coordinate convention: north, east, up by name; NED only where MAVLink has it."""

from __future__ import annotations

import pytest

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
