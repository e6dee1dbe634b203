"""ArduPilot in the loop: ArduCopter flies our quadrotor, ArduRover drives our rover.

Real ArduPilot SITL (ArduCopter, ArduRover) uses our MuJoCo worlds as its JSON physics
backend, in lockstep, and is flown through the same mission API as PX4::

    import multicosim.ardupilot as ardupilot

    simulator = ardupilot.Copter(fidelity="medium", firmware_dir="../shared/ardupilot-sitl")
    with simulator.start() as simulation:
        home = simulation.home
        result = simulation.firmware.send(
            ardupilot.Configuration([ardupilot.Waypoint(home.lat + 2e-4, home.lon, 20.0)])
        )
    assert result.completed, result.reason

``import multicosim.ardupilot`` loads neither MuJoCo nor pymavlink; they load when a
simulation starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..geo import Home
from ..mujoco._config import WorldConfig
from ..px4._config import (
    Configuration,
    FlightSample,
    Geofence,
    MissionResult,
    Waypoint,
    WaypointReached,
)

_LAZY = {
    "BACKENDS": "._simulator",
    "FIRMWARE_FIDELITIES": "._simulator",
    "ArduPilotComponent": "._simulator",
    "ArduPilotNode": "._simulator",
    "ArduPilotSimulation": "._simulator",
    "Backend": "._simulator",
    "Copter": "._simulator",
    "Fidelity": "._simulator",
    "Rover": "._simulator",
    "SITL": "._launch",
    "default_world": "._simulator",
}

__all__ = [
    "BACKENDS",
    "FIRMWARE_FIDELITIES",
    "SITL",
    "ArduPilotComponent",
    "ArduPilotNode",
    "ArduPilotSimulation",
    "Backend",
    "Configuration",
    "Copter",
    "Fidelity",
    "FlightSample",
    "Geofence",
    "Home",
    "MissionResult",
    "Rover",
    "Waypoint",
    "WaypointReached",
    "WorldConfig",
    "default_world",
]

if TYPE_CHECKING:
    from ._launch import SITL
    from ._simulator import (
        BACKENDS,
        FIRMWARE_FIDELITIES,
        ArduPilotComponent,
        ArduPilotNode,
        ArduPilotSimulation,
        Backend,
        Copter,
        Fidelity,
        Rover,
        default_world,
    )


# Former names, kept as deprecated aliases: old name -> new name.
_DEPRECATED = {"FIDELITIES": "FIRMWARE_FIDELITIES"}


def __getattr__(name: str) -> Any:
    if name in _DEPRECATED:
        from .._deps import renamed

        return __getattr__(renamed(__name__, name, _DEPRECATED))
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'multicosim.ardupilot' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
