"""Placing an injector in a scenario: [`inject`][multicosim.attacks._scenarios.inject], and what a
scenario offers it.

A scenario takes faults by implementing
[`SimulatesFaults`][multicosim.attacks._scenarios.SimulatesFaults]: the rover and PX4 remap the
sensor's topic and add an injector (built by
[`add_injector`][multicosim.attacks._scenarios.add_injector]) between world and firmware; ArduPilot
maps the models onto its firmware's own simulated faults:

```python
simulator = rover.Rover(fidelity="low")
attacks.inject(simulator, "gps", [attacks.Jump(offset=attacks.Local(east=3.0), start=2.0)])
simulation = simulator.start()
```

The rover's world publishes the sensor on ``<topic>/raw`` instead (``WorldConfig.sensor_topics``)
and the injector republishes on the topic the controller reads; PX4's autopilot reads
``<topic>/attacked`` instead (``px4.Topics``) and the injector fills it from the world's topic.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

from ..core.errors import ConfigurationError, MulticosimError
from ..placement import Placement
from ._injector import InjectorComponent, InjectorConfig
from .models import Model

__all__ = ["SimulatesFaults", "add_injector", "inject"]


@runtime_checkable
class SimulatesFaults(Protocol):
    """A scenario (a Simulator, not started) that takes sensor faults."""

    def inject_faults(self, sensor: str, models: Sequence[Model], *, name: str | None) -> Any:
        """Put ``models`` on ``sensor``; the component added for it."""
        ...


def inject(
    simulator: object,
    sensor: str,
    models: Sequence[Model],
    *,
    name: str | None = None,
) -> Any:
    """Put an injector with ``models`` on ``sensor`` of the scenario ``simulator``.

    Returns the component that was added (an injector's ``config`` says which topics it
    joins). Raises ConfigurationError for a simulator that takes no faults, an unknown
    sensor, a model that does not fit the sensor's message, or a sensor that already has an
    injector. A scenario whose firmware simulates its sensors' faults itself (ArduPilot)
    gets the models mapped onto those instead.
    """
    if not isinstance(simulator, SimulatesFaults):
        raise ConfigurationError(
            "simulator",
            simulator,
            "a scenario that takes faults (multicosim.rover.Rover, multicosim.px4.PX4, "
            "multicosim.ardupilot.ArduCopter or ArduRover, multicosim.fleet.Fleet, or one with "
            "inject_faults), not started",
        )
    return simulator.inject_faults(sensor, models, name=name)


def add_injector(
    simulator: Any, config: InjectorConfig, *, name: str, placement: str | Placement
) -> InjectorComponent:
    """Add an injector for ``config`` to ``simulator``, run where ``placement`` says (the
    scenario's world's). The scenario moves its topics afterwards, so a failure here leaves
    it unchanged."""
    component = InjectorComponent(config, name=name, placement=placement)
    try:
        simulator.add(component)
    except MulticosimError as exc:
        exc.add_note("add injectors before start(): use the *_simulator fixture, not *_simulation")
        raise
    return component
