"""The world's obstacles in Foxglove's 3D panel: one ``foxglove.SceneUpdate`` at the start of a
flight's trace, read back with the mcap library's reader and checked against the configuration.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from independent import read_independently, validate_foxglove

import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.physics import Box, Cylinder
from multicosim.trace import Recorder

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
# A hangar turned 30 degrees clockwise from north, north-east of home; a tank placed by its
# coordinates, south-east; the flight goes north-west, past both.
HANGAR = Box(length=12, width=4, height=15, yaw=30, north=35, east=25, name="hangar")
TANK_AT = (-20.0, 25.0)  # north, east (m)
TANK_LAT, TANK_LON = PROJ.reproject(*TANK_AT)
TANK = Cylinder(radius=3, height=8, lat=TANK_LAT, lon=TANK_LON)


def rotate(q: dict[str, float], v: tuple[float, float, float]) -> tuple[float, ...]:
    """``v`` rotated by the unit quaternion ``q`` (Foxglove's x, y, z, w)."""
    w, x, y, z = q["w"], q["x"], q["y"], q["z"]
    matrix = (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )
    return tuple(math.fsum(r * c for r, c in zip(row, v, strict=True)) for row in matrix)


@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A low-fidelity PX4 flight among the obstacles: its trace and its layout."""
    path = tmp_path_factory.mktemp("scene")
    world = px4.WorldConfig(obstacles=(HANGAR, TANK))
    lat, lon = PROJ.reproject(20.0, -20.0)
    mission = px4.Configuration([px4.Waypoint(lat, lon, 8.0)], time_limit=60)
    with px4.PX4(world, fidelity="low").start() as simulation, Recorder().attach(simulation) as rec:
        simulation.firmware.send(mission)
    trace = rec.save(path / "px4.mcap")
    return trace, rec.save_layout(path / "px4.layout.json")


def test_the_obstacles_are_one_valid_scene_update_at_the_start(flight: tuple[Path, Path]) -> None:
    schemas, messages = read_independently(flight[0])
    foxglove, validated = validate_foxglove(schemas, messages)
    assert foxglove["mcs/scene"] == "foxglove.SceneUpdate"
    assert validated > 100
    ((log_time, update),) = messages["mcs/scene"]
    assert log_time <= min(t for t, _ in messages["px4/pose"])
    assert log_time == messages["px4/location/truth"][0][0]
    assert update["deletions"] == []
    entities = {e["id"]: e for e in update["entities"]}
    assert set(entities) == {"hangar", "obstacle 1"}
    # In the frame of the vehicle's pose, to stay until the trace ends.
    frame = messages["px4/pose"][0][1]["frame_id"]
    for entity in entities.values():
        assert entity["frame_id"] == frame == "map"
        assert entity["lifetime"] == {"sec": 0, "nsec": 0}
        assert entity["timestamp"] == update["entities"][0]["timestamp"]

    hangar = entities["hangar"]
    assert {m["key"]: m["value"] for m in hangar["metadata"]}["name"] == "hangar"
    assert hangar["cylinders"] == []
    (cube,) = hangar["cubes"]
    assert cube["size"] == pytest.approx({"x": 12.0, "y": 4.0, "z": 15.0})
    # East, north, up: the centre of the footprint, half the height up.
    assert cube["pose"]["position"] == pytest.approx({"x": 25.0, "y": 35.0, "z": 7.5})
    q = cube["pose"]["orientation"]
    assert (q["x"], q["y"]) == pytest.approx((0.0, 0.0))  # a turn about the vertical only
    # Its length (x) points 30 degrees clockwise from north; its width 90 degrees further.
    yaw = math.radians(30)
    assert rotate(q, (1, 0, 0)) == pytest.approx((math.sin(yaw), math.cos(yaw), 0.0))
    assert rotate(q, (0, 1, 0)) == pytest.approx((-math.cos(yaw), math.sin(yaw), 0.0))
    assert 0.0 < cube["color"]["a"] < 1.0

    tank = entities["obstacle 1"]
    assert tank["cubes"] == []
    (cylinder,) = tank["cylinders"]
    assert cylinder["size"] == pytest.approx({"x": 6.0, "y": 6.0, "z": 8.0})
    north, east = TANK_AT
    assert cylinder["pose"]["position"] == pytest.approx({"x": east, "y": north, "z": 4.0})
    assert (cylinder["bottom_scale"], cylinder["top_scale"]) == (1.0, 1.0)


def test_the_3d_panel_shows_the_obstacles_with_the_vehicle(flight: tuple[Path, Path]) -> None:
    layout: dict[str, Any] = json.loads(flight[1].read_text())
    topics = layout["configById"]["3D!mcs"]["topics"]
    assert topics["mcs/scene"]["visible"]
    assert topics["px4/pose"]["visible"]
    assert layout["configById"]["3D!mcs"]["followTfFrame"] == "map"
