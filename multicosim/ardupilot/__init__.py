"""ArduPilot in the loop: ArduCopter flies our quadrotor, ArduRover drives our rover.

Real ArduPilot SITL (ArduCopter, ArduRover) uses our MuJoCo worlds as its JSON physics
backend, in lockstep, and is flown through the same mission API as PX4:

```python
import multicosim.ardupilot as ardupilot

simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir="../shared/ardupilot-sitl")
with simulator.start() as simulation:
    home = simulation.home
    result = simulation.firmware.send(
        ardupilot.Configuration([ardupilot.Waypoint(home.lat + 2e-4, home.lon, 20.0)])
    )
assert result.completed, result.reason
```

``import multicosim.ardupilot`` loads neither MuJoCo nor pymavlink; they load when a
simulation starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports
from ..core.geo import Home
from ..mavlink.mission import (
    Configuration,
    FlightSample,
    Geofence,
    MissionResult,
    Waypoint,
    WaypointReached,
)
from ..mavlink.params import read_params
from ..physics.config import WorldConfig

_LAZY = {
    "FIRMWARE_FIDELITIES": "._simulator",
    "ArduPilotComponent": "._simulator",
    "ArduPilotNode": "._simulator",
    "ArduPilotSimulation": "._simulator",
    "ArduCopter": "._simulator",
    "Fidelity": "._simulator",
    "ArduRover": "._simulator",
    "SITL": ".launch",
    "boot": "._simulator",
    "default_world": "._simulator",
    "frame_period": "._simulator",
}

__all__ = [
    "FIRMWARE_FIDELITIES",
    "SITL",
    "ArduCopter",
    "ArduPilotComponent",
    "ArduPilotNode",
    "ArduPilotSimulation",
    "ArduRover",
    "Configuration",
    "Fidelity",
    "FlightSample",
    "Geofence",
    "Home",
    "MissionResult",
    "Waypoint",
    "WaypointReached",
    "WorldConfig",
    "boot",
    "default_world",
    "frame_period",
    "read_params",
]

if TYPE_CHECKING:
    from ._simulator import (
        FIRMWARE_FIDELITIES,
        ArduCopter,
        ArduPilotComponent,
        ArduPilotNode,
        ArduPilotSimulation,
        ArduRover,
        Fidelity,
        boot,
        default_world,
        frame_period,
    )
    from .launch import SITL


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
