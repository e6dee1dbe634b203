"""The paper's listing 2, the rover with a firmware component, runs as the paper prints it.

Only what cannot be taken as printed differs, and the test checks that nothing else does:

* ``FW_IMG`` and ``GZ_IMG``: the paper's images are in a registry, and images are never
  pulled here. Both become one image built here from the runtime image (``images/rover``):
  its ``controller`` program serves the rover's controller (the paper's controller image),
  and its own command runs the rover's MuJoCo world (the paper's Gazebo image).
* ``mcs.GazeboContainerComponent`` becomes ``mcs.ContainerComponent``: our MuJoCo world in
  its container stands for the paper's Gazebo container. A ContainerComponent given only
  an image runs the image's own command, as the paper's Gazebo component does.
* ``class Mission: speed: int`` takes no constructor arguments as printed, so
  ``Mission(speed=5)`` would raise TypeError: it needs ``@dataclass`` (and its import).

The listing never stops its simulation; the test does, after running it.
"""

from __future__ import annotations

import difflib
import sys
import types
from typing import Any

import msgspec
import pytest

import multicosim.rover as rover
from multicosim.core.version import __version__

# As the paper prints it ("Rover Simulation Example").
PRINTED = """\
import multicosim as mcs

REPO = "ghcr.io/cpslab-asu"
FW_IMG = f"{REPO}/examples/rover/controller"
GZ_IMG = f"{REPO}/examples/rover/gazebo"

class Mission:
    speed: int

port = 5556
rover = mcs.FirmwareComponent(
    image=FW_IMG,
    command="controller --port {port}",
    port=port,
)
gazebo = mcs.GazeboContainerComponent(
    image=GZ_IMG,
)

simulator = mcs.ContainerSimulator()
simulator.add(gazebo)

node_id = simulator.add(rover)
simulation = simulator.start()
node = simulation.get(node_id)
trajectory = node.send(Mission(speed=5))
"""

# As it runs here: the lines in CHANGED differ, every other line is the paper's.
RUN = """\
import multicosim as mcs
from dataclasses import dataclass

REPO = "ghcr.io/cpslab-asu"
FW_IMG = ROVER_IMAGE
GZ_IMG = ROVER_IMAGE

@dataclass
class Mission:
    speed: int

port = 5556
rover = mcs.FirmwareComponent(
    image=FW_IMG,
    command="controller --port {port}",
    port=port,
)
gazebo = mcs.ContainerComponent(
    image=GZ_IMG,
)

simulator = mcs.ContainerSimulator()
simulator.add(gazebo)

node_id = simulator.add(rover)
simulation = simulator.start()
node = simulation.get(node_id)
trajectory = node.send(Mission(speed=5))
"""

CHANGED = {
    "removed": [
        'FW_IMG = f"{REPO}/examples/rover/controller"',
        'GZ_IMG = f"{REPO}/examples/rover/gazebo"',
        "gazebo = mcs.GazeboContainerComponent(",
    ],
    "added": [
        "from dataclasses import dataclass",
        "FW_IMG = ROVER_IMAGE",
        "GZ_IMG = ROVER_IMAGE",
        "@dataclass",
        "gazebo = mcs.ContainerComponent(",
    ],
}


def test_the_run_listing_differs_from_the_printed_one_only_where_the_module_says() -> None:
    diff = list(difflib.ndiff(PRINTED.splitlines(), RUN.splitlines()))
    removed = [line[2:] for line in diff if line.startswith("- ")]
    added = [line[2:] for line in diff if line.startswith("+ ")]
    assert {"removed": removed, "added": added} == CHANGED


def test_paper_listing_2_runs_the_rover_with_its_firmware_in_containers(
    engine: Any, image: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    from multicosim.docker import build_derived

    tag = build_derived("rover", {}, tag=f"multicosim/rover:{__version__}")
    # Run as the module a user's file would be (its @dataclass looks its module up).
    module = types.ModuleType("listing")
    monkeypatch.setitem(sys.modules, "listing", module)
    listing: dict[str, Any] = module.__dict__
    listing["ROVER_IMAGE"] = tag
    try:
        exec(compile(RUN, "listing-2", "exec"), listing)
    finally:
        simulation = listing.get("simulation")
        if simulation is not None:
            simulation.stop()
    # The listing declares no reply type: the reply is the trajectory as plain data.
    trajectory = msgspec.convert(listing["trajectory"], rover.Trajectory)
    assert trajectory.completed, trajectory.reason
    assert trajectory.states() == ["wait", "drive", "turn", "drive_again", "done"]
    assert max(s.speed for s in trajectory) > 4.5  # Mission(speed=5) reached the controller
    names = [c.name for c in listing["simulation"].containers()]
    assert names == ["rover", "controller"]  # the world is named by its image
