"""The paper's PX4 classes: ``PX4Component``, the ``PX4`` simulator and its simulation.

Fidelity decides the models and where they run (the mission logic is the same code):

=========  ==========================  ====================================================
fidelity   world                       execution
=========  ==========================  ====================================================
low        point mass, ideal sensors   world, autopilot and ground station in this process
medium     MJCF quadrotor in MuJoCo,   world and autopilot as two local processes stepped
           noisy sensors               in lockstep, exchanging MAVLink HIL frames; ground
                                       station in this process
=========  ==========================  ====================================================
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Any, Literal

import msgspec

from .._errors import ConfigurationError, MessageTypeError, MulticosimError
from .._interfaces import Component, Node, NodeId
from .._local import (
    InProcessFirmwareComponent,
    InProcessFirmwareNode,
    LocalEnvironment,
    ParticipantComponent,
    ProcessComponent,
    ProcessSimulation,
    ProcessSimulator,
)
from .._messages import type_name
from ._autopilot import Autopilot, AutopilotSpec
from ._config import Configuration, Geofence, MissionResult, MuJoCo, Topics
from ._gcs import GcsSpec, ground_station
from ._world import QuadrotorWorld, WorldSpec

__all__ = ["PX4", "Fidelity", "PX4Component", "PX4Node", "PX4Simulation", "WorldComponent"]

Fidelity = Literal["low", "medium"]
Backend = Literal["process"]
FIDELITIES = ("low", "medium")
LOW_PERIOD = 0.1  # a 10 Hz loop suffices for a point mass and keeps a minute of flight >= 1000x


def _check_fidelity(fidelity: object) -> None:
    if fidelity not in FIDELITIES:
        raise ConfigurationError("fidelity", fidelity, "'low' or 'medium'")


def _in_process(fidelity: str, process: bool | None) -> bool:
    return not (process if process is not None else fidelity == "medium")


def _participant_command(factory: str, spec: msgspec.Struct) -> list[str]:
    return [
        sys.executable,
        "-m",
        "multicosim",
        "participant",
        factory,
        "--config",
        msgspec.json.encode(spec).decode(),
    ]


@dataclasses.dataclass(frozen=True)
class WorldComponent:
    """The quadrotor world as a component (point mass at low fidelity, MuJoCo at medium)."""

    world: MuJoCo = dataclasses.field(default_factory=MuJoCo)
    fidelity: Fidelity = "low"
    name: str = "world"
    process: bool | None = None

    def __post_init__(self) -> None:
        _check_fidelity(self.fidelity)
        if not isinstance(self.world, MuJoCo):
            raise ConfigurationError("world", self.world, "a px4.MuJoCo configuration")

    @property
    def spec(self) -> WorldSpec:
        """The world participant's configuration."""
        low = self.fidelity == "low"
        return WorldSpec(
            model="point_mass" if low else "mujoco",
            world=self.world,
            wire="native" if _in_process(self.fidelity, self.process) else "mavlink",
            point_mass_period=LOW_PERIOD,
        )

    def start(self, environment: LocalEnvironment) -> Node:
        """Start the world in this process or as a process, per fidelity."""
        spec = self.spec
        if _in_process(self.fidelity, self.process):
            return ParticipantComponent(lambda: QuadrotorWorld(spec), self.name).start(environment)
        command = _participant_command("multicosim.px4._world:world", spec)
        return ProcessComponent(command, name=self.name).start(environment)


class PX4Node:
    """The PX4 firmware node: ``send(Configuration) -> MissionResult`` flies a mission.

    ``send`` acts as the ground station (the reference's MAVSDK script): it validates the
    configuration against the geofence, sets parameters, uploads the mission, arms, starts
    it and records the trajectory until the mission ends or its time limit passes.
    """

    def __init__(
        self,
        name: str,
        gcs: InProcessFirmwareNode[Configuration, MissionResult],
        autopilot: Node,
        component: PX4Component,
    ) -> None:
        self.name = name
        self._gcs = gcs
        self._autopilot = autopilot
        self._component = component
        self._stopped = False

    @property
    def autopilot(self) -> Autopilot | None:
        """The live autopilot object when it runs in this process (for inspection)."""
        return getattr(self._autopilot, "participant", None)

    def send(self, msg: Configuration) -> MissionResult:
        """Fly the mission in ``msg`` and return its result."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        if not isinstance(msg, Configuration):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(Configuration)} (the message type of {self.name!r})"
            )
        msg.check_geofence(self._component.world.home, self._component.geofence)
        return self._gcs.send(msg)

    def stop(self) -> None:
        """Stop the ground station and the autopilot; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        from .._simulation import stop_all

        stop_all(
            [(f"{self.name}.gcs", self._gcs.stop), (self.name, self._autopilot.stop)],
            f"component {self.name!r}",
        )


@dataclasses.dataclass(frozen=True)
class PX4Component:
    """PX4 (our PX4-compatible autopilot plus its ground station) for any ProcessSimulator.

    ``world`` tells it where home is and which topics carry the sensors (``topics``
    overrides the autopilot's side only, to read from an injector); ``params`` sets PX4
    parameters (``MPC_XY_CRUISE``, ``NAV_ACC_RAD``, ...); ``geofence`` bounds missions.
    """

    world: MuJoCo = dataclasses.field(default_factory=MuJoCo)
    fidelity: Fidelity = "low"
    name: str = "px4"
    geofence: Geofence = dataclasses.field(default_factory=Geofence)
    params: dict[str, float] = dataclasses.field(default_factory=dict)
    telemetry_rate: float | None = None
    topics: Topics | None = None
    process: bool | None = None

    @property
    def rate(self) -> float:
        """Telemetry (and trajectory sampling) rate: 10 Hz at low fidelity, else 20 Hz."""
        if self.telemetry_rate is not None:
            return self.telemetry_rate
        return 10.0 if self.fidelity == "low" else 20.0

    def __post_init__(self) -> None:
        _check_fidelity(self.fidelity)
        if not isinstance(self.world, MuJoCo):
            raise ConfigurationError("world", self.world, "a px4.MuJoCo configuration")
        if not isinstance(self.geofence, Geofence):
            raise ConfigurationError("geofence", self.geofence, "a px4.Geofence")
        self.spec  # noqa: B018 - validates params, rates and topics now, before any start

    @property
    def spec(self) -> AutopilotSpec:
        """The autopilot participant's configuration."""
        low = self.fidelity == "low"
        params = {
            "GF_MAX_HOR_DIST": self.geofence.radius,
            "GF_MAX_VER_DIST": self.geofence.max_alt,
            **self.params,
        }
        return AutopilotSpec(
            airframe="point_mass" if low else "quadrotor",
            period=LOW_PERIOD if low else self.world.period,
            topics=self.topics or self.world.topics,
            uplink=f"{self.name}/mavlink/up",
            downlink=f"{self.name}/mavlink/down",
            wire="native" if _in_process(self.fidelity, self.process) else "mavlink",
            telemetry_rate=self.rate,
            params=params,
        )

    def start(self, environment: LocalEnvironment) -> PX4Node:
        """Start the autopilot (in-process or as a process) and the ground station."""
        spec = self.spec
        if _in_process(self.fidelity, self.process):
            autopilot: Node = ParticipantComponent(lambda: Autopilot(spec), self.name).start(
                environment
            )
        else:
            command = _participant_command("multicosim.px4._autopilot:autopilot", spec)
            autopilot = ProcessComponent(command, name=self.name).start(environment)
        try:
            gcs_spec = GcsSpec(
                uplink=spec.uplink,
                downlink=spec.downlink,
                truth=self.world.topics.truth,
                period=1.0 / self.rate,
            )
            gcs = InProcessFirmwareComponent(
                ground_station(gcs_spec, f"{self.name}.gcs"), name=f"{self.name}.gcs"
            ).start(environment)
        except BaseException:
            autopilot.stop()
            raise
        return PX4Node(self.name, gcs, autopilot, self)


class PX4Simulation:
    """A running PX4 simulation: ``firmware`` flies missions, ``world`` is the physics node."""

    def __init__(
        self, simulation: ProcessSimulation, firmware_id: NodeId[PX4Node], world_id: NodeId[Node]
    ) -> None:
        self.simulation = simulation
        self.firmware: PX4Node = simulation.get(firmware_id)
        self.world: Node = simulation.get(world_id)

    @property
    def time(self) -> float:
        """Current simulated time (s)."""
        return self.simulation.time

    def get(self, node_id: NodeId[Any]) -> Any:
        """The node ``node_id`` names."""
        return self.simulation.get(node_id)

    def advance(self, duration: float) -> None:
        """Let the world and autopilot run ``duration`` simulated seconds without a mission."""
        self.simulation.advance(duration)

    def stop(self) -> None:
        """Stop every node; idempotent."""
        self.simulation.stop()

    def __enter__(self) -> PX4Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class PX4:
    """A Simulator with the quadrotor world and PX4 already added (the paper's ``px4.PX4``).

    ``fidelity`` chooses the models ("low": point mass in-process, "medium": MuJoCo, world
    and autopilot as processes); ``seed`` fixes every random source; ``realtime`` paces the
    simulation to wall time (for external ground stations). More components (injectors,
    monitors) can be added with ``add`` before ``start``.
    """

    def __init__(
        self,
        world: MuJoCo | None = None,
        *,
        fidelity: Fidelity = "low",
        backend: Backend = "process",
        seed: int = 0,
        realtime: float | None = None,
        geofence: Geofence | None = None,
        params: dict[str, float] | None = None,
        telemetry_rate: float | None = None,
        autopilot_topics: Topics | None = None,
        run_dir: str | None = None,
    ) -> None:
        world = world if world is not None else MuJoCo()
        if not isinstance(world, MuJoCo):
            raise ConfigurationError("world", world, "a px4.MuJoCo configuration")
        _check_fidelity(fidelity)
        if backend != "process":
            raise ConfigurationError(
                "backend",
                backend,
                "'process' (PX4 in containers needs a PX4 image; see multicosim.px4.real)",
            )
        self.world = world
        self.fidelity = fidelity
        self._sim = ProcessSimulator(seed=seed, realtime=realtime, run_dir=run_dir)
        self.world_id: NodeId[Node] = self._sim.add(WorldComponent(world, fidelity))
        self.firmware_id: NodeId[PX4Node] = self._sim.add(
            PX4Component(
                world,
                fidelity,
                geofence=geofence or Geofence(),
                params=dict(params or {}),
                telemetry_rate=telemetry_rate,
                topics=autopilot_topics,
            )
        )

    def add(self, component: Component[LocalEnvironment, Any]) -> NodeId[Any]:
        """Add another component (an injector, a monitor) to the simulation."""
        return self._sim.add(component)

    def start(self) -> PX4Simulation:
        """Start the world and PX4 (and anything added); return the simulation."""
        return PX4Simulation(self._sim.start(), self.firmware_id, self.world_id)
