"""The quadrotor PX4 and ArduCopter fly: PX4's ``none_iris`` airframe as one description for
the MuJoCo body and the autopilots' mixers, its vehicle plug-in for the world, and its sensor
suite (MAVLink's HIL messages with PX4's Gazebo sensor noise).

* ``airframe``: the rotors, mass and inertia (no MuJoCo import: the mixers read it);
* ``vehicle``: ``QuadrotorVehicle``, the body in the MuJoCo world;
* ``sensors``: ``HilSensors``, what the world publishes from the vehicle's state;
* ``topics``: the topics the world publishes and reads.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports
from .airframe import NONE_IRIS, Airframe, Rotor
from .topics import SENSORS, Topics, world_topics

_LAZY = {"HilSensors": ".sensors", "QuadrotorVehicle": ".vehicle"}

__all__ = [
    "NONE_IRIS",
    "SENSORS",
    "Airframe",
    "HilSensors",
    "QuadrotorVehicle",
    "Rotor",
    "Topics",
    "world_topics",
]

if TYPE_CHECKING:
    from .sensors import HilSensors
    from .vehicle import QuadrotorVehicle

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
