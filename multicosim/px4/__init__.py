"""The PX4 scenario: the paper's mission API on MuJoCo, flown by real PX4 or a built-in one.

```python
import multicosim.px4 as px4

world = px4.WorldConfig()                                   # the paper's px4.Gazebo()
simulator = px4.PX4(world, fidelity="low")             # adds the world and PX4 itself
with simulator.start() as simulation:
    result = simulation.firmware.send(
        px4.Configuration([px4.Waypoint(lat=47.3980, lon=8.5460, alt=25.0)])
    )
assert result.completed

# Real PX4 SITL (a px4_sitl_default build) flying the same world, in lockstep:
px4.PX4(world, fidelity="medium", firmware=px4.SITL(binary="build/px4_sitl_default/bin/px4"))

# Real PX4 as the top level of a falsifying search (see multicosim.search.falsify):
levels = ("low", "medium", px4.sitl_level(simulate, px4.SITL(binary=...)))
```

``import multicosim.px4`` loads neither MuJoCo nor pymavlink; they load when a simulation
starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports
from ..mavlink.mission import (
    Configuration,
    FlightSample,
    Geofence,
    Home,
    MissionResult,
    Waypoint,
    WaypointReached,
)
from ..mavlink.params import read_params
from ..physics.config import WorldConfig
from ..quadrotor.topics import Topics

Gazebo = WorldConfig  # the paper's name for the world configuration

_LAZY = {
    "Fidelity": "..core.fidelity",
    "FIDELITIES": "..core.fidelity",
    "HIGH_FIDELITY_WORLD": ".scenario",
    "PX4": ".scenario",
    "PX4Component": ".scenario",
    "PX4Node": ".scenario",
    "PX4Simulation": ".scenario",
    "SITL": ".sitl",
    "SITL_LEVEL": ".levels",
    "sitl_level": ".levels",
    "WorldComponent": ".scenario",
}

__all__ = [
    "FIDELITIES",
    "HIGH_FIDELITY_WORLD",
    "PX4",
    "SITL",
    "SITL_LEVEL",
    "Configuration",
    "Fidelity",
    "FlightSample",
    "Gazebo",
    "Geofence",
    "Home",
    "MissionResult",
    "PX4Component",
    "PX4Node",
    "PX4Simulation",
    "Topics",
    "Waypoint",
    "WaypointReached",
    "WorldComponent",
    "WorldConfig",
    "read_params",
    "sitl_level",
]

if TYPE_CHECKING:
    from ..core.fidelity import FIDELITIES, Fidelity
    from .levels import SITL_LEVEL, sitl_level
    from .scenario import (
        HIGH_FIDELITY_WORLD,
        PX4,
        PX4Component,
        PX4Node,
        PX4Simulation,
        WorldComponent,
    )
    from .sitl import SITL


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
