"""Several vehicles in one world, each with the autopilot chosen for it, on one clock.

```python
from multicosim import fleet, px4
from multicosim.physics import Pose

simulator = fleet.Fleet(
    {"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(north=40.0))},
    fidelity="medium",
)
with simulator.start() as simulation:
    result = simulation.fly({"alpha": mission_a, "bravo": mission_b})
result.encounter.min_separation()
```

* [`scenario`][multicosim.f16.arch.Benchmark.scenario]: [`Fleet`][multicosim.fleet.Fleet],
  [`PX4Vehicle`][multicosim.fleet.PX4Vehicle],
  [`FleetSimulation`][multicosim.fleet.FleetSimulation];
* ``results``: [`FleetResult`][multicosim.fleet.FleetResult],
  [`Encounter`][multicosim.fleet.Encounter] (separation, closest approach, losses of well clear,
  collisions between vehicles);
* ``monitor``: the participant that measures every pair; ``world``: the world of a
  fleet at medium and high fidelity.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports

_LAZY = {
    **dict.fromkeys(
        ("ArduPilotVehicle", "Fleet", "FleetSimulation", "Member", "PX4Vehicle"), ".scenario"
    ),
    **dict.fromkeys(
        (
            "Approach",
            "Encounter",
            "FleetMissions",
            "FleetResult",
            "LossOfWellClear",
            "VehicleCollision",
        ),
        ".results",
    ),
}

__all__ = [
    "Approach",
    "ArduPilotVehicle",
    "Encounter",
    "Fleet",
    "FleetMissions",
    "FleetResult",
    "FleetSimulation",
    "LossOfWellClear",
    "Member",
    "PX4Vehicle",
    "VehicleCollision",
]

if TYPE_CHECKING:
    from .results import (
        Approach,
        Encounter,
        FleetMissions,
        FleetResult,
        LossOfWellClear,
        VehicleCollision,
    )
    from .scenario import ArduPilotVehicle, Fleet, FleetSimulation, Member, PX4Vehicle

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
