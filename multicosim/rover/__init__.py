"""The rover scenario: an Ackermann rover driven by a finite-state-automaton controller.

The paper's second case study. [`Rover`][multicosim.rover.Rover] is a Simulator that builds the
world and the controller for a fidelity level; [`controller`][multicosim.rover.controller] is the
firmware (``@multicosim.firmware``) that turns a [`Mission`][multicosim.rover.Mission] into a
[`Trajectory`][multicosim.rover.Trajectory]:

```python
import multicosim.rover as rover

simulation = rover.Rover(fidelity="medium").start()
trajectory = simulation.controller.send(rover.Mission(speed=5.0))
simulation.stop()
```

Importing this package does not import MuJoCo (the low-fidelity world is kinematic).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports
from ._automaton import TERMINAL, Automaton, Observation, State
from ._controller import controller
from ._kinematic import KinematicWorld, kinematic_world
from ._messages import (
    ABORT_TOPIC,
    COMMAND_TOPIC,
    MAX_DISTANCE,
    MAX_MISSION_TIME,
    MAX_SPEED,
    MAX_STEERING,
    SENSOR_TOPICS,
    Abort,
    Command,
    Imu,
    MagneticField,
    Mission,
    Position,
    SensedSample,
    Trajectory,
    WheelSpeed,
)
from ._scenario import (
    CONTROLLER,
    FIDELITIES,
    Fidelity,
    Rover,
    RoverSimulation,
    controller_component,
    default_noise,
    default_world,
    planned_endpoint,
    world_command,
    world_component,
)
from ._vehicle import (
    ACCELERATION,
    AXLE_HEIGHT,
    REACH,
    TRACK,
    WHEEL_RADIUS,
    WHEEL_WIDTH,
    WHEELBASE,
    RoverWorldConfig,
    SensorNoise,
    ackermann,
    heading_from_field,
    yaw_from_quaternion,
)

__all__ = [
    "ABORT_TOPIC",
    "ACCELERATION",
    "AXLE_HEIGHT",
    "COMMAND_TOPIC",
    "CONTROLLER",
    "FIDELITIES",
    "MAX_DISTANCE",
    "MAX_MISSION_TIME",
    "MAX_SPEED",
    "MAX_STEERING",
    "REACH",
    "SENSOR_TOPICS",
    "TERMINAL",
    "TRACK",
    "WHEELBASE",
    "WHEEL_RADIUS",
    "WHEEL_WIDTH",
    "Abort",
    "Automaton",
    "Command",
    "Fidelity",
    "Imu",
    "KinematicWorld",
    "MagneticField",
    "Mission",
    "Observation",
    "Position",
    "Rover",
    "RoverSimulation",
    "RoverVehicle",
    "RoverWorldConfig",
    "SensedSample",
    "SensorNoise",
    "State",
    "Trajectory",
    "WheelSpeed",
    "ackermann",
    "controller",
    "controller_component",
    "default_noise",
    "default_world",
    "heading_from_field",
    "kinematic_world",
    "planned_endpoint",
    "rover_world",
    "world_command",
    "world_component",
    "yaw_from_quaternion",
]

# The MuJoCo body imports mujoco: it loads on first use.
_LAZY = {"RoverVehicle": ".body", "rover_world": ".body"}

if TYPE_CHECKING:
    from .body import RoverVehicle, rover_world

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
