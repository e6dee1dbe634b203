"""Fixtures of the fleet scenario (registered by the multicosim plugin).

``fleet_simulation`` is a started
[`multicosim.fleet.FleetSimulation`][multicosim.fleet.FleetSimulation] of the vehicles
``fleet_vehicles`` names (override it in a module or conftest), at the fidelity, placement and seed
the options and the ``fidelity`` marker select, stopped when the test ends:

```python
@pytest.fixture
def fleet_vehicles():
    return {"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(north=40))}

@pytest.mark.fidelity("low", "medium")
def test_they_keep_apart(fleet_simulation):
    result = fleet_simulation.fly({"alpha": ..., "bravo": ...})
    assert result.encounter.min_separation() > 5.0
```

``fleet_simulator`` is the unstarted [`multicosim.fleet.Fleet`][multicosim.fleet.Fleet];
``fleet_world`` its world's configuration and ``fleet_well_clear`` the volume its encounter judges.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

from multicosim.core.fidelity import check_fidelity

from .simulations import tracked

if TYPE_CHECKING:
    from multicosim.fleet import Fleet, FleetSimulation
    from multicosim.physics import WellClear, WorldConfig
    from multicosim.placement import Placement

__all__ = [
    "fleet_simulation",
    "fleet_simulator",
    "fleet_vehicles",
    "fleet_well_clear",
    "fleet_world",
]


@pytest.fixture
def fleet_vehicles() -> dict[str, Any]:
    """The fleet's vehicles by name (default: two built-in PX4 quadrotors 40 m apart)."""
    from multicosim.fleet import PX4Vehicle
    from multicosim.physics import Pose

    return {"alpha": PX4Vehicle(), "bravo": PX4Vehicle(start=Pose(north=40.0))}


@pytest.fixture
def fleet_world() -> WorldConfig | None:
    """The fleet's world configuration (None: the fidelity's default)."""
    return None


@pytest.fixture
def fleet_well_clear() -> WellClear | str:
    """The volume the encounter judges (a WellClear or a preset's name; default NMAC)."""
    return "NMAC"


@pytest.fixture
def fleet_simulator(
    mcs_fidelity: str,
    mcs_placement: Placement,
    mcs_seed: int,
    mcs_simulations: Any,
    fleet_vehicles: dict[str, Any],
    fleet_world: WorldConfig | None,
    fleet_well_clear: WellClear | str,
) -> Fleet:
    """An unstarted fleet; whatever it starts is stopped at teardown."""
    from multicosim.fleet import Fleet

    simulator = Fleet(
        fleet_vehicles,
        fidelity=check_fidelity(mcs_fidelity),
        placement=mcs_placement,
        seed=mcs_seed,
        world=fleet_world,
        well_clear=fleet_well_clear,
    )
    return tracked(simulator, mcs_simulations)


@pytest.fixture
def fleet_simulation(fleet_simulator: Fleet) -> FleetSimulation:
    """A started fleet (every vehicle's world and autopilot, the monitor, the ground
    station); stopped at teardown."""
    return fleet_simulator.start()
