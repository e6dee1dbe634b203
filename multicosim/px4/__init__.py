"""The PX4 scenario: the paper's mission API on MuJoCo, flown by real PX4 or a built-in one.

::

    import multicosim.px4 as px4

    world = px4.MuJoCo()                                   # the paper's px4.Gazebo()
    simulator = px4.PX4(world, fidelity="low")             # adds the world and PX4 itself
    with simulator.start() as simulation:
        result = simulation.firmware.send(
            px4.Configuration([px4.Waypoint(lat=47.3980, lon=8.5460, alt=25.0)])
        )
    assert result.completed

    # Real PX4 SITL (a px4_sitl_default build) flying the same world, in lockstep:
    px4.PX4(world, fidelity="medium", firmware=px4.SITL(binary="build/px4_sitl_default/bin/px4"))

    # Real PX4 as the top level of a falsifying search (see multicosim.falsify):
    levels = ("low", "medium", px4.sitl_level(simulate, px4.SITL(binary=...)))

``import multicosim.px4`` loads neither MuJoCo nor pymavlink; they load when a simulation
starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._config import (
    Configuration,
    FlightSample,
    Geofence,
    Home,
    MissionResult,
    MuJoCo,
    Topics,
    Waypoint,
    WaypointReached,
)

Gazebo = MuJoCo  # the paper's name for the world configuration

_LAZY = {
    "BACKENDS": "._simulator",
    "Backend": "._simulator",
    "Fidelity": "._simulator",
    "FIDELITIES": "._simulator",
    "HIGH_FIDELITY_WORLD": "._simulator",
    "PX4": "._simulator",
    "PX4Component": "._simulator",
    "PX4Node": "._simulator",
    "PX4Simulation": "._simulator",
    "SITL": "._real",
    "SITL_LEVEL": "._levels",
    "sitl_level": "._levels",
    "WorldComponent": "._simulator",
}

__all__ = [
    "BACKENDS",
    "FIDELITIES",
    "HIGH_FIDELITY_WORLD",
    "PX4",
    "SITL",
    "SITL_LEVEL",
    "Backend",
    "Configuration",
    "Fidelity",
    "FlightSample",
    "Gazebo",
    "Geofence",
    "Home",
    "MissionResult",
    "MuJoCo",
    "PX4Component",
    "PX4Node",
    "PX4Simulation",
    "Topics",
    "Waypoint",
    "WaypointReached",
    "WorldComponent",
    "sitl_level",
]

if TYPE_CHECKING:
    from ._levels import SITL_LEVEL, sitl_level
    from ._real import SITL
    from ._simulator import (
        BACKENDS,
        FIDELITIES,
        HIGH_FIDELITY_WORLD,
        PX4,
        Backend,
        Fidelity,
        PX4Component,
        PX4Node,
        PX4Simulation,
        WorldComponent,
    )


# Former names, kept as deprecated aliases: old name -> new name.
_DEPRECATED = {"Sample": "FlightSample"}


def __getattr__(name: str) -> Any:
    if name in _DEPRECATED:
        from .._deps import renamed

        return globals()[renamed(__name__, name, _DEPRECATED)]
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'multicosim.px4' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
