"""Fixtures of the rover scenario (registered by the multicosim plugin).

``rover_simulation`` is a started
[`multicosim.rover.RoverSimulation`][multicosim.rover.RoverSimulation] at the fidelity, placement
and seed the options and the ``fidelity`` marker select; it is stopped when the test ends, whatever
happens:

```python
@pytest.mark.fidelity("low", "medium")
def test_mission(rover_simulation):
    trajectory = rover_simulation.controller.send(Mission(speed=3.0))
    assert trajectory.completed
```

``rover_simulator`` is the unstarted [`multicosim.rover.Rover`][multicosim.rover.Rover], for tests
that add components (an injector between world and controller) before starting it.
With ``--mcs-placement=docker`` the world and the controller run as containers of the runtime
image (rebuilt first if the source changed); where no Docker engine runs the test is skipped
with the reason (a failure with ``MCS_REQUIRE_DOCKER=1``).
Heavy imports happen inside the fixtures, so collecting a suite costs nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

from multicosim.core.fidelity import check_fidelity

from .simulations import tracked

if TYPE_CHECKING:
    from multicosim.physics import WorldConfig
    from multicosim.placement import Placement
    from multicosim.rover import Rover, RoverSimulation, SensorNoise

__all__ = [
    "rover_noise",
    "rover_simulation",
    "rover_simulator",
    "rover_world_config",
]


@pytest.fixture
def rover_world_config() -> WorldConfig | None:
    """The world configuration of ``rover_simulator`` (None: the fidelity's default).

    Override it in a test module or conftest to change timestep, solver or topics.
    """
    return None


@pytest.fixture
def rover_noise() -> SensorNoise | None:
    """The sensor noise of ``rover_simulator`` (None: the fidelity's default)."""
    return None


@pytest.fixture
def rover_simulator(
    mcs_fidelity: str,
    mcs_placement: Placement,
    mcs_seed: int,
    mcs_simulations: Any,
    rover_world_config: WorldConfig | None,
    rover_noise: SensorNoise | None,
) -> Rover:
    """An unstarted rover Simulator; whatever it starts is stopped at teardown."""
    from multicosim.rover import Rover

    rover = Rover(
        fidelity=check_fidelity(mcs_fidelity),
        placement=mcs_placement,
        seed=mcs_seed,
        world=rover_world_config,
        noise=rover_noise,
    )
    return tracked(rover, mcs_simulations)


@pytest.fixture
def rover_simulation(rover_simulator: Rover) -> RoverSimulation:
    """A started rover simulation (world + FSA controller); stopped at teardown."""
    return rover_simulator.start()
