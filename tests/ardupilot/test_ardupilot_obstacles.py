"""Real ArduCopter among our obstacles: it hits the wall across its way, and says so.

Needs an ArduPilot SITL (``--mcs-ardupilot-dir`` or ``MCS_ARDUPILOT_DIR``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from ardupilot_helpers import wp

import multicosim.ardupilot as ardupilot
from multicosim.physics import Box
from multicosim.quadrotor.airframe import NONE_IRIS
from multicosim.trace import SCENE_CHANNEL, Recorder, read_trace


def test_arducopter_flown_through_a_wall_collides_with_it(
    ardupilot_dir: str, tmp_path: Path
) -> None:
    wall = Box(length=4, width=10, height=30, north=25, east=0)
    world = dataclasses.replace(ardupilot.default_world("copter", "medium"), obstacles=(wall,))
    simulator = ardupilot.ArduCopter(world, fidelity="medium", firmware_dir=ardupilot_dir)
    with simulator.start() as simulation, Recorder().attach(simulation) as recorder:
        config = ardupilot.Configuration([wp(world.home, 50, 0, 8)], time_limit=200.0)
        result = simulation.firmware.send(config)
    assert not result.completed
    assert result.collision is not None
    assert result.collision.obstacle == 0
    assert result.collision.speed > 2.0
    assert result.reason.startswith("collision with obstacle 0")
    assert result.min_clearance <= 0.05
    # Before it flew, home was 23 m from the wall's south face (less the vehicle's sphere).
    assert result.trajectory[0].clearance == pytest.approx(23 - NONE_IRIS.radius, abs=0.5)
    # Its trace shows the wall in 3-D, where the vehicle's pose is drawn.
    trace = read_trace(recorder.save(tmp_path / "ardupilot.mcap"))
    (scene,) = trace.topic(SCENE_CHANNEL)
    (entity,) = scene.data["entities"]
    (cube,) = entity["cubes"]
    assert entity["id"] == "obstacle 0"
    assert entity["frame_id"] == trace.topic("ardupilot/pose")[0].data["frame_id"]
    assert cube["size"] == pytest.approx({"x": 4.0, "y": 10.0, "z": 30.0})
    assert cube["pose"]["position"] == pytest.approx({"x": 0.0, "y": 25.0, "z": 15.0})
