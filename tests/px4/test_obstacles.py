"""Obstacles, collisions and wind on the PX4 scenario: low, medium and (configured) real PX4.

A mission flown north through a box hits it; one flown past reports the clearance that plain
geometry gives.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

import multicosim.px4 as px4
from multicosim.core.fidelity import check_fidelity
from multicosim.core.geo import LocalProjection
from multicosim.physics import Box, Cylinder
from multicosim.px4.scenario import default_world
from multicosim.quadrotor.airframe import NONE_IRIS
from multicosim.search.requirements import Requirement
from multicosim.trace import OBSTACLES_CHANNEL, SCENE_CHANNEL, Recorder, read_trace
from multicosim.trace._plot import figure

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
RADIUS = NONE_IRIS.radius
# A wall 4 m deep (north), 10 m wide and 30 m high across the way north; a pole off to the east.
WALL = Box(length=4, width=10, height=30, north=30, east=0, name="wall")
POLE = Cylinder(radius=2, height=20, north=0, east=40)


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


@pytest.fixture
def px4_world(mcs_fidelity: str) -> px4.WorldConfig:
    """The fidelity's world with the wall and the pole."""
    return dataclasses.replace(default_world(check_fidelity(mcs_fidelity)), obstacles=(WALL, POLE))


def _tolerance(fidelity: str) -> float:
    # The point mass follows the straight line; a flying quadrotor wanders a little from it.
    return 0.15 if fidelity == "low" else 1.0


@pytest.mark.fidelity("low", "medium")
def test_a_mission_through_a_box_collides(px4_simulation: px4.PX4Simulation) -> None:
    result = px4_simulation.firmware.send(px4.Configuration([wp(60, 0, 10)], time_limit=120))
    assert not result.completed
    collision = result.collision
    assert collision is not None
    assert (collision.obstacle, collision.name) == (0, "wall")  # by name, as in its world
    assert result.reason.startswith("collision with obstacle 0 ('wall')")
    assert collision.speed > 2.0  # it hit the wall at cruise, not standing
    # It hit the wall's south face (28 m north) with its body's sphere.
    at_hit = min(result.trajectory, key=lambda s: abs(s.time - collision.time))
    north, _ = PROJ.project(at_hit.true_lat, at_hit.true_lon)
    assert north == pytest.approx(28.0 - RADIUS, abs=1.0)
    assert any(s.collision for s in result.trajectory)
    assert result.min_clearance <= 0.05


@pytest.mark.fidelity("low", "medium")
def test_a_mission_past_the_box_reports_its_clearance(
    px4_simulation: px4.PX4Simulation, mcs_fidelity: str
) -> None:
    result = px4_simulation.firmware.send(px4.Configuration([wp(60, 20, 10)], time_limit=120))
    assert result.completed, result.reason
    assert result.collision is None
    assert not any(s.collision for s in result.trajectory)
    # The straight line from home to (60, 20) passes the wall's corner (28 north, 5 east) at
    # |28 * 1 - 5 * 3| / sqrt(10) m; below the wall's top that is also the footprint's gap.
    analytic = 13 / math.sqrt(10) - RADIUS
    assert result.min_clearance == pytest.approx(analytic, abs=_tolerance(mcs_fidelity))
    flat = min(s.footprint_clearance for s in result.trajectory)
    assert flat == pytest.approx(analytic, abs=_tolerance(mcs_fidelity))
    # At home, before it flies, the wall's south face (28 m north) is nearer than the pole.
    assert result.trajectory[0].footprint_clearance == pytest.approx(28 - RADIUS, abs=0.5)
    # Requirements read the clearance like any signal.
    margin = Requirement("always (clearance >= 1.5)").robustness(result.trajectory)
    assert margin == pytest.approx(result.min_clearance - 1.5, abs=1e-6)
    assert Requirement("always (clearance >= 5)").robustness(result.trajectory) < 0


@pytest.mark.fidelity("low")
def test_the_trace_and_its_plot_show_the_obstacles(tmp_path: Path) -> None:
    world = px4.WorldConfig(obstacles=(WALL, POLE))
    with px4.PX4(world, fidelity="low").start() as simulation, Recorder().attach(simulation) as rec:
        simulation.firmware.send(px4.Configuration([wp(60, 20, 10)], time_limit=120))
    trace = read_trace(rec.save(tmp_path / "px4.mcap"))
    (message,) = trace.topic(OBSTACLES_CHANNEL)
    wall, pole = message.data["obstacles"]
    assert (wall["name"], pole["name"]) == ("wall", "obstacle 1")
    assert (wall["height"], pole["height"]) == (30, 20)
    corners = {(round(p["north"], 6), round(p["east"], 6)) for p in wall["footprint"]}
    assert corners == {(32.0, 5.0), (32.0, -5.0), (28.0, -5.0), (28.0, 5.0)}
    assert all(
        math.hypot(p["north"], p["east"] - 40) == pytest.approx(2.0) for p in pole["footprint"]
    )
    # The same obstacles in 3-D: a cube for the wall, a cylinder for the pole.
    (scene,) = trace.topic(SCENE_CHANNEL)
    entities = {e["id"]: (len(e["cubes"]), len(e["cylinders"])) for e in scene.data["entities"]}
    assert entities == {"wall": (1, 0), "obstacle 1": (0, 1)}
    patches = {p.get_gid() for ax in figure(trace).axes for p in ax.patches}
    assert {"obstacle/wall", "obstacle/obstacle 1"} <= patches
