"""Placing an injector in the shipped scenarios (the rover and PX4 Simulators).

:func:`inject` remaps the sensor's topic, builds the injector for the scenario's fidelity and
backend (in-process at low fidelity, a local process above, a container on the Docker
backend) and adds it so that it steps after the world and before the firmware::

    simulator = rover.Rover(fidelity="low")
    attacks.inject(simulator, "gps", [attacks.Jump(offset=(3.0, 0.0, 0.0), start=2.0)])
    simulation = simulator.start()

The rover's world publishes the sensor on ``<topic>/raw`` instead (``WorldConfig.sensor_topics``)
and the injector republishes on the topic the controller reads; PX4's autopilot reads
``<topic>/attacked`` instead (``px4.Topics``) and the injector fills it from the world's topic.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, overload

from .._errors import ConfigurationError, MulticosimError
from ._injector import InjectorComponent, InjectorConfig
from ._models import Model
from ._sensors import Vehicle, canonical

__all__ = ["SimulatesFaults", "inject", "vehicle_of"]


def vehicle_of(simulator: object) -> Vehicle:
    """Which scenario ``simulator`` is (``"rover"`` or ``"px4"``); ConfigurationError if neither."""
    from ..rover import Rover

    if isinstance(simulator, Rover):
        return "rover"
    from ..px4 import PX4

    if isinstance(simulator, PX4):
        return "px4"
    raise ConfigurationError(
        "simulator", simulator, "a multicosim.rover.Rover or multicosim.px4.PX4 (not started)"
    )


class SimulatesFaults(Protocol):
    """A scenario whose firmware simulates sensor faults itself (ArduPilot's SITL)."""

    def inject_faults(self, sensor: str, models: Sequence[Model], *, name: str | None) -> Any:
        """Map ``models`` onto the firmware's own faults of ``sensor``; the component added."""
        ...


@overload
def inject(
    simulator: SimulatesFaults, sensor: str, models: Sequence[Model], *, name: str | None = None
) -> Any: ...
@overload
def inject(
    simulator: Any, sensor: str, models: Sequence[Model], *, name: str | None = None
) -> InjectorComponent: ...
def inject(
    simulator: Any,
    sensor: str,
    models: Sequence[Model],
    *,
    name: str | None = None,
) -> Any:
    """Put an injector with ``models`` on ``sensor`` of the scenario ``simulator``.

    Returns the component that was added (its ``config`` says which topics it joins). Raises
    ConfigurationError for an unknown sensor, a model that does not fit the sensor's
    message, or a sensor that already has an injector. A scenario whose firmware simulates
    its sensors' faults itself (ArduPilot) gets the models mapped onto those instead.
    """
    inner: Any = simulator
    faults = getattr(inner, "inject_faults", None)
    if callable(faults):
        return faults(sensor, models, name=name)
    vehicle = vehicle_of(simulator)
    sensor = canonical(vehicle, sensor)
    name = name or f"{sensor}-injector"
    if vehicle == "rover":
        from ..rover import SENSOR_TOPICS

        target = SENSOR_TOPICS[sensor]
        source = f"{target}/raw"
        if inner.config.world.sensor_topics.get(sensor, target) != target:
            raise ConfigurationError(
                "sensor", sensor, "a sensor without an injector (combine models in one)"
            )
        config = InjectorConfig(
            vehicle="rover",
            sensor=sensor,
            source=source,
            target=target,
            period=inner.config.world.period,
            models=tuple(models),
        )
        in_process = inner.fidelity == "low"
    else:
        from ..px4._config import world_topics
        from ..px4._simulator import LOW_PERIOD

        source = getattr(world_topics(inner.world), sensor)
        target = f"{source}/attacked"
        if getattr(inner.autopilot_topics, sensor) != source:
            raise ConfigurationError(
                "sensor", sensor, "a sensor without an injector (combine models in one)"
            )
        # Where the world runs: in this process at low fidelity, and as real PX4's simulator.
        in_process = inner.backend == "process" and (
            inner.fidelity == "low" or inner.firmware is not None
        )
        config = InjectorConfig(
            vehicle="px4",
            sensor=sensor,
            source=source,
            target=target,
            period=LOW_PERIOD if inner.fidelity == "low" else inner.world.period,
            models=tuple(models),
            # The world's wire: what the scenario's world and autopilot exchange (Structs at
            # low fidelity, on either backend; MAVLink frames between processes above).
            wire=inner.wire,
        )
    component = InjectorComponent(config, name=name, process=not in_process)
    # Validate everything before the simulator changes: move the topic last.
    added = component.container() if inner.backend == "docker" else component
    try:
        inner.add(added)
    except MulticosimError as exc:
        exc.add_note("add injectors before start(): use the *_simulator fixture, not *_simulation")
        raise
    # The rover's world publishes the sensor on the injector's source; PX4's autopilot reads
    # it from the injector's target.
    if vehicle == "rover":
        inner.publish_sensor_on(sensor, source)
    else:
        inner.read_sensor_from(sensor, target)
    return component
