"""The rover scenario as a Simulator: world + FSA controller at a chosen fidelity.

::

    import multicosim.rover as rover

    simulation = rover.Rover(fidelity="medium").start()
    trajectory = simulation.controller.send(rover.Mission(speed=5.0))
    simulation.stop()

Fidelity picks the models, the backend picks where they run:

=========  ===============================  ==================================================
fidelity   world                            ``backend="process"`` / ``backend="docker"``
=========  ===============================  ==================================================
low        kinematic bicycle, ideal         world and controller in this process (no IPC) /
           sensors                          each a container of the runtime image
medium     MuJoCo, 2.5 ms step, 40 Hz       world and controller as local processes /
           sensors, realistic noise         each a container on the simulation's network
high       MuJoCo, 0.5 ms step, 200 solver  as medium
           iterations, 100 Hz sensors,
           realistic noise
=========  ===============================  ==================================================

The components run the same programs everywhere (``world_command``, ``CONTROLLER_COMMAND``),
so a seed gives the same trajectory on both backends at the same fidelity.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, Literal, TypeVar, cast, overload

from ..core.errors import ConfigurationError
from ..core.fidelity import BACKENDS, FIDELITIES, Backend, Fidelity, check_fidelity
from ..core.interfaces import CommunicationNode, Component, Node, NodeId
from ..local import (
    InProcessComponent,
    InProcessFirmwareComponent,
    LocalEnvironment,
    ProcessComponent,
    ProcessFirmwareComponent,
    ProcessSimulation,
    ProcessSimulator,
    ScenarioSimulation,
    participant_command,
    required_images,
)
from ..physics.config import WorldConfig
from ._controller import controller
from ._kinematic import KinematicWorld
from ._messages import SENSOR_TOPICS, Mission, Trajectory
from ._vehicle import WHEELBASE, RoverWorldConfig, SensorNoise

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..attacks import InjectorComponent, Model
    from ..docker import ContainerEnvironment, ContainerSimulator
    from ..trace import TraceOptions

__all__ = [
    "BACKENDS",
    "CONTROLLER_COMMAND",
    "FIDELITIES",
    "Backend",
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


# The component programs (the same in a local process and in a container).
CONTROLLER_COMMAND = ("multicosim", "serve", "multicosim.rover:controller", "--port", "{port}")
# In a container the firmware must listen on the container's network address: its port is
# published to the host from there.
CONTAINER_PORT = 5556


def world_command(
    config: RoverWorldConfig | None = None, fidelity: Fidelity = "medium"
) -> list[str]:
    """The command running the rover world configured by ``config``.

    The MuJoCo world, or the kinematic one at ``fidelity="low"``; without ``config``, the
    world and sensor noise ``fidelity`` uses by default.
    """
    config = config or _default_config(fidelity)
    factory = (
        "multicosim.rover:kinematic_world"
        if fidelity == "low"
        else "multicosim.rover.body:rover_world"
    )
    return participant_command(factory, config)


def _check_backend(backend: object) -> None:
    if backend not in BACKENDS:
        raise ConfigurationError("backend", backend, f"one of {BACKENDS}")


def _runtime_image() -> str:
    from ..docker import RUNTIME_IMAGE

    return RUNTIME_IMAGE


@overload
def world_component(
    fidelity: Fidelity = ...,
    config: RoverWorldConfig | None = ...,
    *,
    name: str = ...,
    backend: Literal["process"] = ...,
) -> Component[LocalEnvironment, Node]: ...
@overload
def world_component(
    fidelity: Fidelity = ...,
    config: RoverWorldConfig | None = ...,
    *,
    name: str = ...,
    backend: Backend,
) -> Component[ContainerEnvironment, Node]: ...
def world_component(
    fidelity: Fidelity = "medium",
    config: RoverWorldConfig | None = None,
    *,
    name: str = WORLD_NAME,
    backend: Backend = "process",
) -> Component[Any, Node]:
    """The rover world at ``fidelity``, run where ``backend`` says.

    Process backend: the kinematic world in-process (low) or a MuJoCo process. Docker
    backend: a participant container of the runtime image, at every fidelity.
    """
    _check_backend(backend)
    config = config or _default_config(fidelity)
    if backend == "docker":
        from ..docker import ContainerComponent

        return ContainerComponent(_runtime_image(), world_command(config, fidelity), name=name)
    if fidelity == "low":
        return InProcessComponent(lambda: KinematicWorld(config), name=name)
    return ProcessComponent(["python", "-m", *world_command(config, fidelity)], name=name)


@overload
def controller_component(
    fidelity: Fidelity = ..., *, name: str = ..., backend: Literal["process"] = ...
) -> Component[LocalEnvironment, CommunicationNode[Mission, Trajectory]]: ...
@overload
def controller_component(
    fidelity: Fidelity = ..., *, name: str = ..., backend: Backend
) -> Component[ContainerEnvironment, CommunicationNode[Mission, Trajectory]]: ...
def controller_component(
    fidelity: Fidelity = "medium", *, name: str = CONTROLLER_NAME, backend: Backend = "process"
) -> Component[Any, CommunicationNode[Mission, Trajectory]]:
    """The FSA controller, run where ``backend`` says.

    Process backend: in-process at low fidelity, else a firmware process. Docker backend: a
    ContainerFirmwareComponent of the runtime image, at every fidelity.
    """
    _check_backend(backend)
    if backend == "docker":
        from ..docker import ContainerFirmwareComponent

        return ContainerFirmwareComponent(
            image=_runtime_image(),
            command=[*CONTROLLER_COMMAND, "--host", "0.0.0.0"],
            port=CONTAINER_PORT,
            msgtype=Mission,
            replytype=Trajectory,
            name=name,
        )
    if fidelity == "low":
        return InProcessFirmwareComponent(controller, name=name)
    return ProcessFirmwareComponent(
        ["python", "-m", *CONTROLLER_COMMAND],
        msgtype=Mission,
        replytype=Trajectory,
        name=name,
    )


class RoverSimulation(ScenarioSimulation):
    """A running rover scenario: ``controller`` takes missions, ``get`` finds other nodes."""

    def __init__(
        self,
        simulation: ProcessSimulation,
        controller_id: NodeId[CommunicationNode[Mission, Trajectory]],
        world_id: NodeId[Node],
        fidelity: Fidelity,
        backend: Backend = "process",
        world_config: WorldConfig | None = None,
    ) -> None:
        super().__init__(simulation)
        self.fidelity = fidelity
        self.backend: Backend = backend
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
            f"RoverSimulation(fidelity={self.fidelity!r}, backend={self.backend!r}, "
            f"time={self.time:g})"
        )


class Rover:
    """The rover scenario Simulator: a world and the FSA controller, at a fidelity level.

    ``fidelity`` picks the models: ``low`` (kinematic bicycle, ideal sensors), ``medium``
    (MuJoCo, realistic sensor noise) or ``high`` (MuJoCo at a finer timestep with more
    solver iterations and faster sensors). ``backend`` picks where they run: ``process``
    (in this process at low fidelity, else world and controller as local processes in
    lockstep) or ``docker`` (each a container of ``multicosim.docker.RUNTIME_IMAGE`` on the
    simulation's network; build it with ``multicosim images build``).
    ``world`` overrides the physics world configuration, ``noise`` the sensor noise.
    Components added with ``add`` (injectors, monitors) step between the world and the
    controller, in add order; on the docker backend they may be containers too.
    """

    def __init__(
        self,
        fidelity: Fidelity = "medium",
        backend: Backend = "process",
        seed: int = 0,
        world: WorldConfig | None = None,
        noise: SensorNoise | None = None,
        *,
        realtime: float | None = None,
    ) -> None:
        check_fidelity(fidelity)
        _check_backend(backend)
        if world is not None and not isinstance(world, WorldConfig):
            raise ConfigurationError("world", world, "a multicosim.physics.WorldConfig or None")
        if noise is not None and not isinstance(noise, SensorNoise):
            raise ConfigurationError("noise", noise, "a SensorNoise or None")
        self.fidelity: Fidelity = fidelity
        self.backend: Backend = backend
        self.config = RoverWorldConfig(
            world=world or default_world(fidelity), noise=noise or default_noise(fidelity)
        )
        self._simulator: ProcessSimulator | ContainerSimulator
        if backend == "docker":
            from ..docker import ContainerSimulator

            self._simulator = ContainerSimulator(seed=seed, realtime=realtime)
        else:
            self._simulator = ProcessSimulator(seed=seed, realtime=realtime)
        self.seed = seed
        self._world_id = self._add(world_component(fidelity, self.config, backend=backend))
        self._started = False

    def _add(self, component: Component[ContainerEnvironment, NodeT]) -> NodeId[NodeT]:
        # Typed for the docker backend, which takes every component; the process backend
        # gets no container component (``add`` refuses them, the scenario's own match it).
        return self._simulator.add(cast("Component[LocalEnvironment, NodeT]", component))

    def add(self, component: Component[ContainerEnvironment, NodeT]) -> NodeId[NodeT]:
        """Add a component; it steps after the world and before the controller.

        Any component runs on the docker backend; container components need it.
        """
        if self.backend != "docker" and required_images(component):
            raise ConfigurationError(
                "component",
                component,
                "a component of the process backend (containers need backend='docker')",
            )
        return self._add(component)

    def inject_faults(
        self, sensor: str, models: Sequence[Model], *, name: str | None = None
    ) -> InjectorComponent:
        """Put an injector with ``models`` on ``sensor`` (see :func:`multicosim.attacks.inject`).

        The world publishes the sensor on ``<topic>/raw`` and the injector republishes it on
        the topic the controller reads.
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
            self,
            config,
            name=name or f"{sensor}-injector",
            in_process=self.fidelity == "low",
            backend=self.backend,
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
        world_node = world_component(self.fidelity, self.config, backend=self.backend)
        self._simulator.replace(
            self._world_id, cast("Component[LocalEnvironment, Node]", world_node)
        )

    def start(self) -> RoverSimulation:
        """Start the world, the added components and the controller."""
        if not self._started:
            self._started = True
            self._controller_id = self._add(
                controller_component(self.fidelity, backend=self.backend)
            )
        simulation = self._simulator.start()
        return RoverSimulation(
            simulation,
            self._controller_id,
            self._world_id,
            self.fidelity,
            self.backend,
            self.config.world,
        )

    def __repr__(self) -> str:
        return f"Rover(fidelity={self.fidelity!r}, backend={self.backend!r}, seed={self.seed})"


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
