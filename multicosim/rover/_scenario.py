"""The rover scenario as a Simulator: world + FSA controller at a chosen fidelity.

::

    import multicosim.rover as rover

    simulation = rover.Rover(fidelity="medium").start()
    trajectory = simulation.controller.send(rover.Mission(speed=5.0))
    simulation.stop()
"""

from __future__ import annotations

import math
from typing import Literal, TypeVar

from .._errors import ConfigurationError
from .._interfaces import CommunicationNode, Component, Node, NodeId
from .._local import (
    FirmwareProcessComponent,
    InProcessFirmwareComponent,
    LocalEnvironment,
    ParticipantComponent,
    ProcessComponent,
    ProcessSimulation,
    ProcessSimulator,
    config_json,
)
from ..mujoco._config import WorldConfig
from ._controller import controller
from ._kinematic import KinematicWorld
from ._messages import Mission, Trajectory
from ._vehicle import WHEELBASE, RoverWorldConfig, SensorNoise

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

Fidelity = Literal["low", "medium", "high"]
Backend = Literal["process"]
FIDELITIES: tuple[Fidelity, ...] = ("low", "medium", "high")
BACKENDS: tuple[str, ...] = ("process",)

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


# The component programs (the same in a local process and in a container).
CONTROLLER_COMMAND = ("multicosim", "serve", "multicosim.rover:controller", "--port", "{port}")


def world_command(config: RoverWorldConfig) -> list[str]:
    """The command running the MuJoCo rover world configured by ``config``."""
    return [
        "multicosim",
        "participant",
        "multicosim.mujoco:rover_world",
        "--config",
        config_json(config),
    ]


def world_component(
    fidelity: Fidelity = "medium",
    config: RoverWorldConfig | None = None,
    *,
    name: str = WORLD_NAME,
) -> Component[LocalEnvironment, Node]:
    """The rover world at ``fidelity``: kinematic in-process (low) or a MuJoCo process."""
    config = config or RoverWorldConfig(
        world=default_world(fidelity), noise=default_noise(fidelity)
    )
    if fidelity == "low":
        return ParticipantComponent(lambda: KinematicWorld(config), name=name)
    return ProcessComponent(["python", "-m", *world_command(config)], name=name)


def controller_component(
    fidelity: Fidelity = "medium", *, name: str = CONTROLLER_NAME
) -> Component[LocalEnvironment, CommunicationNode[Mission, Trajectory]]:
    """The FSA controller: in-process at low fidelity, else a firmware process."""
    if fidelity == "low":
        return InProcessFirmwareComponent(controller, name=name)
    return FirmwareProcessComponent(
        ["python", "-m", *CONTROLLER_COMMAND],
        msgtype=Mission,
        replytype=Trajectory,
        name=name,
    )


class RoverSimulation:
    """A running rover scenario: ``controller`` takes missions, ``get`` finds other nodes."""

    def __init__(
        self,
        simulation: ProcessSimulation,
        controller_id: NodeId[CommunicationNode[Mission, Trajectory]],
        world_id: NodeId[Node],
        fidelity: Fidelity,
    ) -> None:
        self.simulation = simulation
        self.fidelity = fidelity
        self._controller_id = controller_id
        self._world_id = world_id

    @property
    def controller(self) -> CommunicationNode[Mission, Trajectory]:
        """The FSA controller: ``controller.send(Mission(...))`` returns the Trajectory."""
        return self.simulation.get(self._controller_id)

    @property
    def world(self) -> Node:
        """The world node (a participant in-process, or a process)."""
        return self.simulation.get(self._world_id)

    @property
    def time(self) -> float:
        """Current simulated time (s)."""
        return self.simulation.time

    @property
    def seed(self) -> int:
        """The simulation's seed."""
        return self.simulation.seed

    def get(self, node_id: NodeId[NodeT]) -> NodeT:
        """The node ``node_id`` names (ids come from ``Rover.add``)."""
        return self.simulation.get(node_id)

    def advance(self, duration: float) -> None:
        """Run the world for ``duration`` simulated seconds without a mission."""
        self.simulation.advance(duration)

    def stop(self) -> None:
        """Stop the controller and the world; idempotent."""
        self.simulation.stop()

    def __enter__(self) -> RoverSimulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __repr__(self) -> str:
        return f"RoverSimulation(fidelity={self.fidelity!r}, time={self.time:g})"


class Rover:
    """The rover scenario Simulator: a world and the FSA controller, at a fidelity level.

    ``fidelity``: ``low`` (kinematic bicycle, controller in-process, no IPC), ``medium``
    (MuJoCo world and controller as separate processes in lockstep) or ``high`` (MuJoCo at
    a finer timestep). ``world`` overrides the physics world configuration, ``noise`` the
    sensor noise (ideal at low fidelity, realistic above). Components added with ``add``
    (injectors, monitors) step between the world and the controller, in add order.
    """

    def __init__(
        self,
        fidelity: Fidelity = "medium",
        backend: str = "process",
        seed: int = 0,
        world: WorldConfig | None = None,
        noise: SensorNoise | None = None,
        *,
        realtime: float | None = None,
    ) -> None:
        if fidelity not in FIDELITIES:
            raise ConfigurationError("fidelity", fidelity, f"one of {FIDELITIES}")
        if backend not in BACKENDS:
            raise ConfigurationError(
                "backend", backend, f"one of {BACKENDS} (docker comes with the Docker backend)"
            )
        if world is not None and not isinstance(world, WorldConfig):
            raise ConfigurationError("world", world, "a multicosim.mujoco.WorldConfig or None")
        if noise is not None and not isinstance(noise, SensorNoise):
            raise ConfigurationError("noise", noise, "a SensorNoise or None")
        self.fidelity: Fidelity = fidelity
        self.backend = backend
        self.config = RoverWorldConfig(
            world=world or default_world(fidelity), noise=noise or default_noise(fidelity)
        )
        self._simulator = ProcessSimulator(seed=seed, realtime=realtime)
        self.seed = seed
        self._world_id = self._simulator.add(world_component(fidelity, self.config))
        self._started = False

    def add(self, component: Component[LocalEnvironment, NodeT]) -> NodeId[NodeT]:
        """Add a component; it steps after the world and before the controller."""
        return self._simulator.add(component)

    def start(self) -> RoverSimulation:
        """Start the world, the added components and the controller."""
        if not self._started:
            self._started = True
            self._controller_id = self._simulator.add(controller_component(self.fidelity))
        simulation = self._simulator.start()
        return RoverSimulation(simulation, self._controller_id, self._world_id, self.fidelity)

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
