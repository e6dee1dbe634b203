"""Sensor faults and attacks: an injector between a sensor and the firmware that reads it.

The paper's noisy-GPS case study. The world publishes a sensor on a remapped topic; the
injector reads it there, corrupts it with seeded, combinable models, each active from
``start`` to ``end``, and publishes it where the firmware expects it:

```python
import multicosim.attacks as attacks
import multicosim.rover as rover

simulator = rover.Rover(fidelity="low")
attacks.inject(
    simulator,
    "gps",
    [
        attacks.Gaussian(std=0.5),
        attacks.Jump(offset=attacks.Local(north=4.0), start=3.0, ramp=2.0),
    ],
)
with simulator.start() as simulation:
    trajectory = simulation.controller.send(rover.Mission(speed=3.0))
```

Models: [`Gaussian`][multicosim.attacks.Gaussian] noise, [`Bias`][multicosim.attacks.Bias],
random-walk [`Drift`][multicosim.attacks.Drift], [`Jump`][multicosim.attacks.Jump] (a spoof,
optionally ramped), [`Stream`][multicosim.attacks.Stream] (an offset another component publishes,
such as an FMU's environment model), [`Dropout`][multicosim.attacks.Dropout],
[`Delay`][multicosim.attacks.Delay]. Sensors: the rover's ``position`` (alias ``gps``),
``magnetometer``, ``imu``, ``wheel_speed``; PX4's ``gps``, ``mag``, ``baro``, ``imu``; a vehicle of
your own registers its sensors with [`register`][multicosim.attacks.register]. Quantities (what
additive models offset, ``on=``): positions in metres, by name ([`Local`][multicosim.attacks.Local]:
north, east, up), ``heading`` in radians, fields and rates per body axis.
"""

from __future__ import annotations

from ._injector import PROGRAM, InjectorComponent, InjectorConfig, SensorInjector, injector
from ._scenarios import SimulatesFaults, add_injector, inject
from .models import (
    Additive,
    Bias,
    Delay,
    Drift,
    Dropout,
    Gaussian,
    Jump,
    Local,
    Model,
    Stream,
    Window,
    is_zero,
)
from .sensors import ALIASES, SENSORS, Quantity, Sensor, canonical, register, sensor, vehicles

__all__ = [
    "ALIASES",
    "PROGRAM",
    "SENSORS",
    "Additive",
    "Bias",
    "Delay",
    "Drift",
    "Dropout",
    "Gaussian",
    "InjectorComponent",
    "InjectorConfig",
    "Jump",
    "Local",
    "Model",
    "Quantity",
    "Sensor",
    "SensorInjector",
    "SimulatesFaults",
    "Stream",
    "Window",
    "add_injector",
    "canonical",
    "inject",
    "injector",
    "is_zero",
    "register",
    "sensor",
    "vehicles",
]
