"""The MuJoCo physics world: its configuration, the world participant, the Vehicle protocol.

``WorldConfig`` plays the role of the paper's ``Gazebo(backend=ODE(...), step_size=...)``.
A [`World`][multicosim.physics.World] is a participant that steps MuJoCo in lockstep with the
simulation and hands the vehicle-specific part to a [`Vehicle`][multicosim.physics.Vehicle]: any
object with ``sensors`` (each sensor's name and default topic, which ``WorldConfig.sensor_topics``
may move), and ``load_model()``, ``setup(physics, ctx, topics)``, ``actuate(physics, ctx)`` and
``sense(physics, ctx)``. The world knows no vehicle: the shipped ones live in their own
packages (``multicosim.rover.body``, ``multicosim.quadrotor.vehicle``), and a user's own
is a class in the user's own module:

```python
class Pendulum:  # a multicosim.physics.Vehicle
    def __init__(self) -> None:
        self.sensors = {"angle": "pendulum/angle"}

    def load_model(self) -> Any:
        return mujoco.MjModel.from_xml_string(MJCF)

    def setup(self, physics: Physics, ctx: StepContext, topics: Mapping[str, str]) -> None:
        self.topic = topics["angle"]
        self.torque = ctx.subscribe("pendulum/torque", Torque)
        physics.data.qpos[0] = 0.5  # the initial state; the first readings are of it

    def actuate(self, physics: Physics, ctx: StepContext) -> None:
        if self.torque.latest is not None:
            physics.data.ctrl[0] = self.torque.latest.value

    def sense(self, physics: Physics, ctx: StepContext) -> None:
        ctx.publish(self.topic, Angle(value=float(physics.sensor("angle")[0])))


def world(config: WorldConfig) -> World:
    return World(config, Pendulum())
```

The world also holds obstacles ([`Box`][multicosim.physics.Box],
[`Cylinder`][multicosim.physics.Cylinder]) and wind ([`Wind`][multicosim.physics.Wind]: steady,
gusts, Dryden turbulence) from ``WorldConfig(obstacles=..., wind=...)``. A vehicle that meets them
describes its body ([`Bodied`][multicosim.physics.Bodied]: a ``body`` attribute, a
[`Body`][multicosim.physics.Body] naming its MuJoCo body, the radius that encloses it and its drag)
and returns an ``MjSpec`` from ``load_model()``, so the world can add the obstacles' geoms before
compiling.

``python -m multicosim participant mymodule:world --config JSON`` runs that world as a
process (``multicosim.local.participant_command("mymodule:world", config)`` builds the
command), ``mcs.InProcessComponent(lambda: world(config), name="world")`` in the
simulation's process.

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
from .encounter import (
    ASTM_F3442,
    DO_365,
    NMAC,
    PairSample,
    VehicleContact,
    WellClear,
    closest_approach,
    first_contact,
)
from .fleet import Pose
from .obstacles import Box, Cylinder, Obstacle, Proximity
from .wind import LIGHT, MODERATE, SEVERE, Body, Gust, Wind

__all__ = [
    "ASTM_F3442",
    "DEFAULT_HOME",
    "DEFAULT_MAGNETIC_FIELD",
    "DO_365",
    "INTEGRATORS",
    "LIGHT",
    "MODERATE",
    "NMAC",
    "SEVERE",
    "SOLVERS",
    "Bodied",
    "Body",
    "Box",
    "Cylinder",
    "Gust",
    "Integrator",
    "MemberPhysics",
    "Obstacle",
    "PairSample",
    "Physics",
    "PhysicsDivergedError",
    "Pose",
    "Proximity",
    "Solver",
    "Vehicle",
    "VehicleContact",
    "WellClear",
    "Wind",
    "World",
    "WorldConfig",
    "closest_approach",
    "first_contact",
    "geodetic_to_local",
    "load_model",
    "load_spec",
    "local_to_geodetic",
]

# These import mujoco, so they load on first use.
_LAZY = {
    "Bodied": ".world",
    "MemberPhysics": ".world",
    "Physics": ".world",
    "PhysicsDivergedError": "..core.errors",
    "Vehicle": ".world",
    "World": ".world",
    "load_model": ".world",
    "load_spec": ".world",
}

if TYPE_CHECKING:
    from ..core.errors import PhysicsDivergedError
    from .world import Bodied, MemberPhysics, Physics, Vehicle, World, load_model, load_spec


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
