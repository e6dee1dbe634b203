"""The MuJoCo physics world: configuration, the world participant and shipped vehicles.

``WorldConfig`` plays the role of the paper's ``Gazebo(backend=ODE(...), step_size=...)``.
A :class:`World` is a participant that steps MuJoCo in lockstep with the simulation and
hands the vehicle-specific part (MJCF model, actuator topics, sensors) to a
:class:`Vehicle`; :func:`rover_world` builds the rover scenario's world.

The configuration and coordinate helpers import without MuJoCo; the world itself needs it
(``pip install 'multicosim[mujoco]'``) and raises DependencyMissingError otherwise.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..geo import geodetic_to_local, local_to_geodetic
from ._config import (
    DEFAULT_HOME,
    DEFAULT_MAGNETIC_FIELD,
    INTEGRATORS,
    SOLVERS,
    Integrator,
    Solver,
    WorldConfig,
)

__all__ = [
    "DEFAULT_HOME",
    "DEFAULT_MAGNETIC_FIELD",
    "INTEGRATORS",
    "MODELS",
    "SOLVERS",
    "Integrator",
    "Physics",
    "PhysicsDivergedError",
    "RoverVehicle",
    "Solver",
    "Vehicle",
    "World",
    "WorldConfig",
    "geodetic_to_local",
    "local_to_geodetic",
    "rover_world",
]

# These import mujoco, so they load on first use.
_LAZY = {
    "MODELS": "._world",
    "Physics": "._world",
    "PhysicsDivergedError": ".._errors",
    "Vehicle": "._world",
    "World": "._world",
    "RoverVehicle": "._rover",
    "rover_world": "._rover",
}

if TYPE_CHECKING:
    from .._errors import PhysicsDivergedError
    from ._rover import RoverVehicle, rover_world
    from ._world import MODELS, Physics, Vehicle, World


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'multicosim.mujoco' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
