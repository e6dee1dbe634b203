"""The rover fixture library, through pytester (as a user's suite would use it)."""

from __future__ import annotations

import pytest

SUITE = """
import pytest
import multicosim as mcs
from multicosim.rover import Mission, RoverSimulation

SHORT = Mission(speed=2.0, wait=0.0, distance=1.0, final_distance=1.0)

@pytest.mark.fidelity("low", "medium")
def test_mission(rover_simulation, mcs_fidelity, mcs_seed):
    assert isinstance(rover_simulation, RoverSimulation)
    assert rover_simulation.fidelity == mcs_fidelity
    assert rover_simulation.seed == mcs_seed == 7
    assert rover_simulation.controller.send(SHORT).completed

@pytest.fixture
def rover_world_config():
    from multicosim.physics import WorldConfig
    return WorldConfig(period=0.05, timestep=0.005)

@pytest.mark.fidelity("low")
def test_simulator_takes_configuration_and_components(rover_simulator):
    class Idle:
        period = 0.1
        def setup(self, ctx): pass
        def step(self, ctx): pass
    rover_simulator.add(mcs.InProcessComponent(Idle, name="idle"))
    assert rover_simulator.config.world.period == 0.05
    simulation = rover_simulator.start()
    assert simulation.controller.send(SHORT).completed
"""


def test_rover_fixtures(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_suite=SUITE)
    result = pytester.runpytest(
        "--mcs-fidelity=low,medium", "--mcs-seed=7", "-p", "no:cacheprovider"
    )
    result.assert_outcomes(passed=3, deselected=1)
