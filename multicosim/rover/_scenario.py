"""The rover scenario as a Simulator: world + FSA controller at a chosen fidelity.

```python
import multicosim.rover as rover

simulation = rover.Rover(fidelity="medium").start()
trajectory = simulation.controller.send(rover.Mission(speed=5.0))
simulation.stop()
```

Fidelity picks the models, the placement picks where they run:

=========  ===============================  ==================================================
fidelity   world                            default placement
=========  ===============================  ==================================================
low        kinematic bicycle, ideal         ``in-process``: world and controller in this
           sensors                          process (no IPC)
medium     MuJoCo, 2.5 ms step, 40 Hz       ``process``: world and controller as local
           sensors, realistic noise         processes, in lockstep
high       MuJoCo, 0.5 ms step, 200 solver  as medium
           iterations, 100 Hz sensors,
           realistic noise
=========  ===============================  ==================================================

Any registered placement runs any fidelity (``placement="docker"``: each a container of the
runtime image on the simulation's network). The components run the same programs everywhere
(``world_command``, ``CONTROLLER``), so a seed gives the same trajectory in every placement
at the same fidelity.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, TypeVar

from ..core.errors import ConfigurationError
from ..core.fidelity import FIDELITIES, Fidelity, check_fidelity
from ..core.interfaces import CommunicationNode, Component, Node, NodeId
from ..local import ProcessSimulation, participant_command
from ..physics.config import WorldConfig
from ..placement import (
    FirmwareProgram,
    ParticipantProgram,
    Placement,
    Scenario,
    ScenarioSimulation,
    resolve,
)
from ._messages import SENSOR_TOPICS, Mission, Trajectory
from ._vehicle import WHEELBASE, RoverWorldConfig, SensorNoise

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..attacks import InjectorComponent, Model
    from ..trace import TraceOptions

__all__ = [
    "CONTROLLER",
    "FIDELITIES",
    "Fidelity",
    "Rover",
    "RoverSimulation",
    "controller_component",
    "planned_endpoint",
    "world_command",
    "world_component",
]

NodeT = TypeVar("NodeT", bound=Node)


WORLD_NAME = "world"
CONTROLLER_NAME = "controller"
CONTROLLER = "multicosim.rover:controller"
"""The FSA controller firmware (``multicosim serve multicosim.rover:controller``)."""

# Low fidelity: the kinematic world integrates arcs exactly, so it only needs to publish
# as often as the controller reads (40 Hz divides the usual 10, 20 and 40 Hz loops).
LOW_FIDELITY_WORLD = WorldConfig(period=0.025)
# Medium fidelity: ten MuJoCo steps per exchange, sensors at 40 Hz (twice the controller's
# default rate); each exchange is a round trip between processes, so fewer is faster.
MEDIUM_FIDELITY_WORLD = WorldConfig(timestep=0.0025, period=0.025)
# High fidelity: the model integrated five times finer, more solver iterations, 100 Hz sensors.
HIGH_FIDELITY_WORLD = WorldConfig(timestep=0.0005, iterations=200, period=0.01)


def default_world(fidelity: Fidelity) -> WorldConfig:
    """The world configuration a fidelity level uses unless one is given."""
    if fidelity == "low":
        return LOW_FIDELITY_WORLD
    return HIGH_FIDELITY_WORLD if fidelity == "high" else MEDIUM_FIDELITY_WORLD


def default_noise(fidelity: Fidelity) -> SensorNoise:
    """Ideal sensors at low fidelity, realistic noise above."""
    return SensorNoise() if fidelity == "low" else SensorNoise.realistic()


def _default_config(fidelity: Fidelity) -> RoverWorldConfig:
    return RoverWorldConfig(world=default_world(fidelity), noise=default_noise(fidelity))


def _world_factory(fidelity: Fidelity) -> str:
    return (
        "multicosim.rover:kinematic_world"
        if fidelity == "low"
        else "multicosim.rover.body:rover_world"
    )


def world_command(
    config: RoverWorldConfig | None = None, fidelity: Fidelity = "medium"
) -> list[str]:
    """The command (after ``python -m``) running the rover world configured by ``config``.

    The MuJoCo world, or the kinematic one at ``fidelity="low"``; without ``config``, the
    world and sensor noise ``fidelity`` uses by default.
    """
    return participant_command(_world_factory(fidelity), config or _default_config(fidelity))


def world_component(
    fidelity: Fidelity = "medium",
    config: RoverWorldConfig | None = None,
    *,
    name: str = WORLD_NAME,
    placement: str | Placement | None = None,
) -> Component[Any, Node]:
    """The rover world at ``fidelity`` (kinematic at low, MuJoCo above), run where
    ``placement`` says (None: the fidelity's default)."""
    check_fidelity(fidelity)
    program = ParticipantProgram(
        _world_factory(fidelity), config or _default_config(fidelity), name
    )
    return resolve(placement, fidelity).participant(program)


def controller_component(
    fidelity: Fidelity = "medium",
    *,
    name: str = CONTROLLER_NAME,
    placement: str | Placement | None = None,
) -> Component[Any, CommunicationNode[Mission, Trajectory]]:
    """The FSA controller, run where ``placement`` says (None: the fidelity's default)."""
    check_fidelity(fidelity)
    program = FirmwareProgram(CONTROLLER, name, msgtype=Mission, replytype=Trajectory)
    return resolve(placement, fidelity).firmware(program)


class RoverSimulation(ScenarioSimulation):
    """A running rover scenario: ``controller`` takes missions, ``get`` finds other nodes."""

    def __init__(
        self,
        simulation: ProcessSimulation,
        controller_id: NodeId[CommunicationNode[Mission, Trajectory]],
        world_id: NodeId[Node],
        fidelity: Fidelity,
        placement: Placement,
        world_config: WorldConfig | None = None,
    ) -> None:
        super().__init__(simulation)
        self.fidelity = fidelity
        self.placement = placement
        self.world_config = world_config or default_world(fidelity)
        self._controller_id = controller_id
        self._world_id = world_id

    def trace_options(self) -> TraceOptions:
        """What a recorder of this simulation should know (topic types, Foxglove channels)."""
        from ._trace import trace_options

        return trace_options(self.world_config)

    @property
    def controller(self) -> CommunicationNode[Mission, Trajectory]:
        """The FSA controller: ``controller.send(Mission(...))`` returns the Trajectory."""
        return self.simulation.get(self._controller_id)

    @property
    def world(self) -> Node:
        """The world node (a participant in-process, a process or a container)."""
        return self.simulation.get(self._world_id)

    def __repr__(self) -> str:
        return (
            f"RoverSimulation(fidelity={self.fidelity!r}, placement={self.placement.name!r}, "
            f"time={self.time:g})"
        )


class Rover(Scenario[RoverSimulation]):
    """The rover scenario Simulator: a world and the FSA controller, at a fidelity level.

    ``fidelity`` picks the models: ``low`` (kinematic bicycle, ideal sensors), ``medium``
    (MuJoCo, realistic sensor noise) or ``high`` (MuJoCo at a finer timestep with more
    solver iterations and faster sensors). ``placement`` picks where they run (a registered
    name such as ``"in-process"``, ``"process"``, ``"docker"``; None: this process at low
    fidelity, local processes above). ``world`` overrides the physics world configuration,
    ``noise`` the sensor noise. Components added with ``add`` (injectors, monitors) step
    between the world and the controller, in add order.
    """

    def __init__(
        self,
        fidelity: Fidelity = "medium",
        placement: str | Placement | None = None,
        seed: int = 0,
        world: WorldConfig | None = None,
        noise: SensorNoise | None = None,
        *,
        realtime: float | None = None,
    ) -> None:
        super().__init__(fidelity=fidelity, placement=placement, seed=seed, realtime=realtime)
        if world is not None and not isinstance(world, WorldConfig):
            raise ConfigurationError("world", world, "a multicosim.physics.WorldConfig or None")
        if noise is not None and not isinstance(noise, SensorNoise):
            raise ConfigurationError("noise", noise, "a SensorNoise or None")
        self.config = RoverWorldConfig(
            world=world or default_world(self.fidelity),
            noise=noise or default_noise(self.fidelity),
        )
        self._world_id = self._add_own(self._world())
        self._controller: NodeId[CommunicationNode[Mission, Trajectory]] | None = None

    def _world(self) -> Component[Any, Node]:
        return world_component(self.fidelity, self.config, placement=self.placement)

    def inject_faults(
        self, sensor: str, models: Sequence[Model], *, name: str | None = None
    ) -> InjectorComponent:
        """Put an injector with ``models`` on ``sensor`` (see
        [`multicosim.attacks.inject`][multicosim.attacks.inject]).

        The world publishes the sensor on ``<topic>/raw`` and the injector, placed as the
        world is, republishes it on the topic the controller reads.
        """
        from ..attacks import InjectorConfig, add_injector, canonical
        from . import injectable  # noqa: F401 - registers the rover's sensors

        sensor = canonical("rover", sensor)
        target = SENSOR_TOPICS[sensor]
        if self.config.world.sensor_topics.get(sensor, target) != target:
            raise ConfigurationError(
                "sensor", sensor, "a sensor without an injector (combine models in one)"
            )
        config = InjectorConfig(
            vehicle="rover",
            sensor=sensor,
            source=f"{target}/raw",
            target=target,
            period=self.config.world.period,
            models=tuple(models),
        )
        component = add_injector(
            self, config, name=name or f"{sensor}-injector", placement=self.placement
        )
        self.publish_sensor_on(sensor, config.source)
        return component

    def publish_sensor_on(self, sensor: str, topic: str) -> None:
        """Have the world publish ``sensor`` on ``topic`` instead (before start).

        An injector added with ``add`` then republishes it on the topic the controller reads.
        """
        topics = {**self.config.world.sensor_topics, sensor: topic}
        world = dataclasses.replace(self.config.world, sensor_topics=topics)
        self.config = dataclasses.replace(self.config, world=world)  # checks the sensor name
        self.replace(self._world_id, self._world())

    def start(self) -> RoverSimulation:
        """Start the world, the added components and the controller."""
        if self._controller is None:
            # Last: what the injectors added before start publish reaches it in the instant.
            self._controller = self._add_own(
                controller_component(self.fidelity, placement=self.placement)
            )
        return RoverSimulation(
            self._start_simulation(),
            self._controller,
            self._world_id,
            self.fidelity,
            self.placement,
            self.config.world,
        )


def planned_endpoint(
    mission: Mission,
    start: tuple[float, float] = (0.0, 0.0),
    heading: float = 0.0,
) -> tuple[float, float, float]:
    """Where the plan puts the rover: (x, y, heading) after an ideal run of ``mission``.

    Straight ``distance``, an arc of the steering angle's radius through ``turn_angle``,
    straight ``final_distance``; aborts and timeouts are not part of the plan.
    """
    x, y = start
    x += mission.distance * math.cos(heading)
    y += mission.distance * math.sin(heading)
    radius = WHEELBASE / math.tan(mission.steering)
    turn = mission.turn_angle
    sign = 1.0 if turn > 0 else -1.0
    # The arc's centre lies to the side the rover turns to.
    cx = x - sign * radius * math.sin(heading)
    cy = y + sign * radius * math.cos(heading)
    end_heading = heading + turn
    x = cx + sign * radius * math.sin(end_heading)
    y = cy - sign * radius * math.cos(end_heading)
    x += mission.final_distance * math.cos(end_heading)
    y += mission.final_distance * math.sin(end_heading)
    return x, y, math.remainder(end_heading, math.tau)
