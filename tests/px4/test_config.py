"""Configuration types validate on construction and name the offending field."""

from __future__ import annotations

import math

import msgspec
import pytest
from hypothesis import given
from hypothesis import strategies as st

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection, pressure_altitude, pressure_hpa
from multicosim.px4 import strategies as px4st


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"lat": math.nan, "lon": 8.5, "alt": 10.0}, "lat"),
        ({"lat": 91.0, "lon": 8.5, "alt": 10.0}, "lat"),
        ({"lat": 47.0, "lon": 181.0, "alt": 10.0}, "lon"),
        ({"lat": 47.0, "lon": math.inf, "alt": 10.0}, "lon"),
        ({"lat": 47.0, "lon": 8.5, "alt": -1.0}, "alt"),
        ({"lat": 47.0, "lon": 8.5, "alt": "high"}, "alt"),
    ],
)
def test_bad_waypoints_name_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        px4.Waypoint(**kwargs)  # type: ignore[arg-type]
    assert info.value.field == field


def test_empty_mission_is_refused() -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        px4.Configuration([])
    assert info.value.field == "mission"


def test_mission_of_the_wrong_type_is_refused() -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        px4.Configuration([(47.39, 8.54, 10.0)])  # type: ignore[list-item]
    assert info.value.field == "mission[0]"


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"timestep": 0.0}, "timestep"),
        ({"integrator": "leapfrog"}, "integrator"),
        ({"solver": "magic"}, "solver"),
        ({"iterations": 0}, "iterations"),
        ({"timestep": 0.004, "period": 0.002}, "period"),
    ],
)
def test_bad_world_configurations(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        px4.WorldConfig(**kwargs)  # type: ignore[arg-type]
    assert info.value.field == field


def test_geofence_check_names_the_waypoint() -> None:
    home = px4.Home()
    lat, lon = LocalProjection(home.lat, home.lon).reproject(1500.0, 0.0)
    config = px4.Configuration([px4.Waypoint(home.lat, home.lon, 10), px4.Waypoint(lat, lon, 10)])
    with pytest.raises(mcs.ConfigurationError) as info:
        config.check_geofence(home, px4.Geofence(radius=1000.0))
    assert info.value.field == "mission[1]"
    high = px4.Configuration([px4.Waypoint(home.lat, home.lon, 200.0)])
    with pytest.raises(mcs.ConfigurationError, match="geofence"):
        high.check_geofence(home, px4.Geofence())


def test_configurations_round_trip_as_messages() -> None:
    config = px4.Configuration([px4.Waypoint(47.398, 8.546, 25.0)], end="rtl")
    data = msgspec.msgpack.encode(config)
    assert msgspec.msgpack.decode(data, type=px4.Configuration) == config
    world = px4.WorldConfig(solver="CG", sensor_topics={"gps": "gps/attacked"})
    assert msgspec.json.decode(msgspec.json.encode(world), type=px4.WorldConfig) == world
    bad = b'{"mission": [{"lat": 91, "lon": 8.5, "alt": 1}]}'
    with pytest.raises(msgspec.ValidationError, match="lat"):
        msgspec.json.decode(bad, type=px4.Configuration)


def test_import_is_light() -> None:
    import subprocess
    import sys

    code = (
        "import sys, multicosim.px4 as px4; px4.Waypoint(47.0, 8.0, 1.0); "
        "print(any(m in sys.modules for m in ('mujoco', 'pymavlink')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@given(st.floats(-3000, 3000), st.floats(-3000, 3000))
def test_projection_round_trip(north: float, east: float) -> None:
    proj = LocalProjection(47.397742, 8.545594)
    lat, lon = proj.reproject(north, east)
    n2, e2 = proj.project(lat, lon)
    assert n2 == pytest.approx(north, abs=1e-6)
    assert e2 == pytest.approx(east, abs=1e-6)


def test_pressure_altitude_round_trip() -> None:
    for alt in (0.0, 488.0, 1500.0):
        assert pressure_altitude(pressure_hpa(alt)) == pytest.approx(alt, abs=1e-6)


@given(px4st.missions(distance=(0.0, 500.0)))
def test_generated_missions_are_inside_the_geofence(config: px4.Configuration) -> None:
    config.check_geofence(px4.Home(), px4.Geofence())


@given(px4st.worlds())
def test_generated_worlds_are_valid(world: px4.WorldConfig) -> None:
    assert world.steps_per_period >= 1


def test_public_names() -> None:
    assert set(px4.__all__) == {
        "FIDELITIES",
        "HIGH_FIDELITY_WORLD",
        "PX4",
        "Configuration",
        "Fidelity",
        "Gazebo",
        "Geofence",
        "Home",
        "MissionResult",
        "WorldConfig",
        "PX4Component",
        "PX4Node",
        "PX4Simulation",
        "SITL",
        "FlightSample",
        "SITL_LEVEL",
        "Topics",
        "Waypoint",
        "WaypointReached",
        "WorldComponent",
        "read_params",
        "sitl_level",
    }
    for name in px4.__all__:
        assert getattr(px4, name) is not None
    assert px4.Gazebo is px4.WorldConfig  # the paper's name


def test_hil_helpers_read_and_write_both_wires() -> None:
    import msgspec as ms

    from multicosim.px4 import hil

    gps = hil.HilGps(1_000, 3, 473977420, 85455940, 488_000, 70, 100, 0, 0, 0, 0, 0, 12)
    wires: tuple[hil.Wire, ...] = ("native", "mavlink")
    for wire in wires:
        payload = hil.write(gps, wire)
        assert isinstance(payload, hil.payload_type(wire, hil.HilGps))
        back = hil.read(payload, hil.HilGps)
        assert back == gps
        assert hil.read(payload, hil.HilSensor) is None
        moved = ms.structs.replace(back, lat=back.lat + 100)
        moved_back = hil.read(hil.write(moved, wire), hil.HilGps)
        assert moved_back is not None
        assert moved_back.lat == gps.lat + 100
