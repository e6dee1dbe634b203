"""The MuJoCo physics world: configuration, the world participant and shipped vehicles.

``WorldConfig`` plays the role of the paper's ``Gazebo(backend=ODE(...), step_size=...)``.
A :class:`World` is a participant that steps MuJoCo in lockstep with the simulation and
hands the vehicle-specific part (MJCF model, actuator topics, sensors) to a
:class:`Vehicle`; :func:`rover_world` builds the rover scenario's world.

The configuration and coordinate helpers import without MuJoCo; the world itself needs it
(``pip install 'multicosim[mujoco]'``) and raises DependencyMissingError otherwise.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports
from ..core.geo import geodetic_to_local, local_to_geodetic
from .config import (
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
    "SOLVERS",
    "Integrator",
    "Physics",
    "PhysicsDivergedError",
    "Solver",
    "Vehicle",
    "World",
    "WorldConfig",
    "geodetic_to_local",
    "load_model",
    "local_to_geodetic",
]

# These import mujoco, so they load on first use.
_LAZY = {
    "Physics": ".world",
    "PhysicsDivergedError": "..core.errors",
    "Vehicle": ".world",
    "World": ".world",
    "load_model": ".world",
}

if TYPE_CHECKING:
    from ..core.errors import PhysicsDivergedError
    from .world import Physics, Vehicle, World, load_model


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
