"""The paper's PX4 classes: ``PX4Component``, the ``PX4`` simulator and its simulation.

Fidelity picks the models, the placement where they run (the mission logic is the same code):

=========  ==========================  ====================================================
fidelity   world                       default placement
=========  ==========================  ====================================================
low        point mass, ideal sensors   ``in-process``: world, autopilot and ground station
                                       in this process
medium     MJCF quadrotor in MuJoCo    ``process``: world and autopilot as two local
           (2 ms step), noisy sensors  processes stepped in lockstep, exchanging MAVLink
                                       HIL frames; ground station in this process
high       as medium, 0.5 ms step and  as medium
           twice the solver iterations
=========  ==========================  ====================================================

Any registered placement runs any fidelity: ``placement="docker"`` runs the world and the
autopilot as containers of ``multicosim.docker.RUNTIME_IMAGE``, exchanging what processes
exchange at that fidelity (native messages at low, MAVLink HIL frames above); the ground
station always stays in this process. A seed gives the same flight in every placement at
the same fidelity. Real PX4 (``firmware=SITL(...)``) runs where the placement runs programs
(a local process, a container); the world is then its simulator, in this process beside
PX4's simulator bridge, as Gazebo is PX4's.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec

from ..core.errors import ConfigurationError
from ..core.fidelity import Fidelity, check_fidelity
from ..core.interfaces import Component, Node, NodeId
from ..local import (
    InProcessFirmwareComponent,
    InProcessNode,
    LocalEnvironment,
    required_images,
)
from ..mavlink.gcs import GcsSpec, ground_station
from ..mavlink.hil import Wire
from ..mavlink.mission import Geofence, Home
from ..mavlink.node import MissionNode
from ..physics.config import WorldConfig
from ..placement import ParticipantProgram, Placement, Scenario, ScenarioSimulation, resolve
from ..placement.firmware import FirmwareNodes, ProgramNode, preflight_program
from ..quadrotor.topics import Topics, world_topics
from .autopilot.firmware import Autopilot, AutopilotSpec
from .procedure import PX4Procedure
from .sitl import SENSOR_RATE, SITL, image_of, start_sitl
from .world import WorldSpec

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..attacks import InjectorComponent, Model
    from ..local import ProcessSimulation
    from ..trace import TraceOptions

__all__ = [
    "HIGH_FIDELITY_WORLD",
    "PX4",
    "PX4Component",
    "PX4Node",
    "PX4Simulation",
    "WorldComponent",
    "default_world",
]

LOW_PERIOD = 0.1  # a 10 Hz loop suffices for a point mass and keeps a minute of flight >= 1000x
# High fidelity: the same 100 Hz lockstep, with the rigid body integrated four times finer
# and the constraint solver given twice the iterations.
HIGH_FIDELITY_WORLD = WorldConfig(timestep=0.0005, iterations=100)


def default_world(fidelity: Fidelity) -> WorldConfig:
    """The world configuration a fidelity level uses unless one is given."""
    return HIGH_FIDELITY_WORLD if fidelity == "high" else WorldConfig()


def sitl_period(world: WorldConfig) -> float:
    """The world period real PX4 gets its sensors at: the timestep multiple nearest 250 Hz."""
    steps = max(1, round(1.0 / SENSOR_RATE / world.timestep))
    return round(world.timestep * steps, 9)


def wire_of(fidelity: Fidelity, real_firmware: bool = False) -> Wire:
    """How sensor payloads travel between world and autopilot: native Structs at low fidelity
    and beside real firmware (its world shares its bridge's process, which packs them for
    PX4); above, MAVLink HIL frames, as PX4 SITL exchanges them, wherever the components run.

    Not the placement: packing rounds floats to MAVLink's 32 bits, so a flight is the same
    bits in process, as processes and in containers only if every placement packs.
    """
    return "native" if fidelity == "low" or real_firmware else "mavlink"


@dataclasses.dataclass(frozen=True)
class WorldComponent:
    """The quadrotor world as a component (point mass at low fidelity, MuJoCo above).

    ``placement`` is where it runs (a registered name, a Placement, or None: the fidelity's
    default); ``wire`` how its sensors travel (None: the fidelity's, ``wire_of``; real
    PX4's bridge takes them native).
    """

    world: WorldConfig = dataclasses.field(default_factory=WorldConfig)
    fidelity: Fidelity = "low"
    name: str = "world"
    placement: str | Placement | None = None
    wire: Wire | None = None

    def __post_init__(self) -> None:
        check_fidelity(self.fidelity)
        if not isinstance(self.world, WorldConfig):
            raise ConfigurationError("world", self.world, "a px4.WorldConfig")
        if self.wire not in (None, "native", "mavlink"):
            raise ConfigurationError("wire", self.wire, "None, 'native' or 'mavlink'")
        resolve(self.placement, self.fidelity)

    @property
    def spec(self) -> WorldSpec:
        """The world participant's configuration."""
        low = self.fidelity == "low"
        return WorldSpec(
            model="point_mass" if low else "mujoco",
            world=self.world,
            wire=self.wire or wire_of(self.fidelity),
            point_mass_period=LOW_PERIOD,
        )

    def _placed(self) -> Component[Any, Node]:
        program = ParticipantProgram("multicosim.px4.world:world", self.spec, self.name)
        return resolve(self.placement, self.fidelity).participant(program)

    def required_images(self) -> tuple[str, ...]:
        """The images its placement needs (checked before a run that runs containers starts)."""
        return tuple(required_images(self._placed()))

    def start(self, environment: LocalEnvironment) -> Node:
        """Start the world where its placement runs it."""
        return self._placed().start(environment)


class PX4Node(MissionNode):
    """The PX4 firmware node: ``send(Configuration) -> MissionResult`` flies a mission."""

    component: PX4Component

    @property
    def autopilot(self) -> Autopilot | None:
        """The live autopilot object when it runs in this process (for inspection)."""
        node = self.autopilot_node
        return node.participant if isinstance(node, InProcessNode) else None

    @property
    def firmware_nodes(self) -> FirmwareNodes | None:
        """Real PX4's program and bridges (None for the built-in autopilot)."""
        node = self.autopilot_node
        return node if isinstance(node, FirmwareNodes) else None

    @property
    def program(self) -> ProgramNode | None:
        """Real PX4's process or container (None for the built-in autopilot)."""
        nodes = self.firmware_nodes
        return nodes.program if nodes is not None else None

    @property
    def instance(self) -> int | None:
        """Real PX4's instance number (``px4 -i N``; None for the built-in autopilot)."""
        nodes = self.firmware_nodes
        return nodes.instance if nodes is not None else None

    def flight_logs(self, into: Path) -> list[Path]:
        """Real PX4's ULog files so far (``log/**/*.ulg`` of its working directory; from a
        container, copied into ``into`` first). Empty for the built-in autopilot."""
        nodes = self.firmware_nodes
        return nodes.files("log", ".ulg", into) if nodes is not None else []


@dataclasses.dataclass(frozen=True)
class PX4Component:
    """PX4 plus its ground station, for any lockstep simulator (the paper's ``PX4Component``).

    ``firmware`` picks the autopilot: None for the built-in PX4-compatible one, or a
    [`SITL`][multicosim.px4.SITL] for real PX4 SITL flying the world. ``world`` tells it
    where home is and which topics carry the sensors (``topics`` overrides the autopilot's
    side only, to read from an injector); ``params`` sets PX4 parameters (``MPC_XY_CRUISE``,
    ``NAV_ACC_RAD``, ...); ``geofence`` bounds missions. ``placement`` is where the
    autopilot runs (None: the fidelity's default); the ground station always runs in this
    process.
    """

    world: WorldConfig = dataclasses.field(default_factory=WorldConfig)
    fidelity: Fidelity = "low"
    name: str = "px4"
    geofence: Geofence = dataclasses.field(default_factory=Geofence)
    params: dict[str, float] = dataclasses.field(default_factory=dict)
    telemetry_rate: float | None = None
    topics: Topics | None = None
    placement: str | Placement | None = None
    firmware: SITL | None = None

    @property
    def rate(self) -> float:
        """Telemetry (and trajectory sampling) rate: 10 Hz at low fidelity, else 20 Hz."""
        if self.telemetry_rate is not None:
            return self.telemetry_rate
        return 10.0 if self.fidelity == "low" else 20.0

    def __post_init__(self) -> None:
        check_fidelity(self.fidelity)
        if not isinstance(self.world, WorldConfig):
            raise ConfigurationError("world", self.world, "a px4.WorldConfig")
        if not isinstance(self.geofence, Geofence):
            raise ConfigurationError("geofence", self.geofence, "a px4.Geofence")
        placement = resolve(self.placement, self.fidelity)
        if self.firmware is not None:
            if not isinstance(self.firmware, SITL):
                raise ConfigurationError(
                    "firmware", self.firmware, "None (the built-in autopilot) or a px4.SITL"
                )
            if self.fidelity == "low":
                raise ConfigurationError(
                    "fidelity",
                    self.fidelity,
                    "'medium' or 'high' with real PX4 (it flies the MuJoCo world; low "
                    "fidelity is the built-in autopilot's point mass)",
                )
            preflight_program(
                placement,
                self.name,
                command=self.firmware.binary is not None,
                image=image_of(self.firmware),
                needs="px4.SITL(binary=...) to run PX4 on this machine, or "
                "px4.SITL(image=...) with placement='docker'",
            )
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
            topics=self.topics or world_topics(self.world),
            uplink=f"{self.name}/mavlink/up",
            downlink=f"{self.name}/mavlink/down",
            wire=wire_of(self.fidelity, self.firmware is not None),
            telemetry_rate=self.rate,
            params=params,
            mag_declination=self.world.declination,
        )

    def sitl_params(self) -> dict[str, float]:
        """The parameters real PX4 boots with: the world's declination, fence, ``params``."""
        assert self.firmware is not None
        return {
            # The world's field is the truth PX4 must use, not its own field model's.
            "EKF2_DECL_TYPE": 0,
            "EKF2_MAG_DECL": round(math.degrees(self.world.declination), 3),
            "GF_MAX_HOR_DIST": self.geofence.radius,
            "GF_MAX_VER_DIST": self.geofence.max_alt,
            **self.params,
            **self.firmware.params,
        }

    def autopilot(self, spec: AutopilotSpec | None = None) -> Component[Any, Node]:
        """The built-in autopilot, where it is placed (``spec``: its configuration, None:
        ``self.spec``)."""
        program = ParticipantProgram(
            "multicosim.px4.autopilot.firmware:autopilot", spec or self.spec, self.name
        )
        return resolve(self.placement, self.fidelity).participant(program)

    def required_images(self) -> tuple[str, ...]:
        """The images its placement needs (checked before a run that runs containers starts)."""
        if self.firmware is not None:
            placement = resolve(self.placement, self.fidelity)
            image = image_of(self.firmware)
            return preflight_program(
                placement, self.name, command=self.firmware.binary is not None, image=image
            )
        return tuple(required_images(self.autopilot()))

    def start(self, environment: LocalEnvironment) -> PX4Node:
        """Start the autopilot where it is placed, then the ground station here."""
        spec = self.spec
        if self.firmware is not None:
            return self._start_sitl(environment, spec)
        return self._with_ground_station(environment, self.autopilot().start(environment))

    def trace_options(self, *, member: bool = False, start: Home | None = None) -> TraceOptions:
        """Its trace options: types, decoders, Foxglove channels (``member``, ``start``: as a
        fleet's vehicle, see ``mission_trace``)."""
        from .trace import trace_options

        options = trace_options(self.spec, self.world, self.name, member=member, start=start)
        # Real PX4 runs its own threads: its runs repeat their verdicts, not their bits.
        return dataclasses.replace(options, deterministic=self.firmware is None)

    def gcs_spec(self) -> GcsSpec:
        """What a ground station flying this autopilot needs: its link, the world's truth,
        the telemetry period, and real PX4's longer waits."""
        spec = self.spec
        # PX4's estimator needs its GPS checks passed (about 10 s) before it arms; its
        # MAVLink thread answers in wall time, so commands get more slack.
        slack: dict[str, Any] = (
            {"preflight_timeout": 120.0, "command_timeout": 3.0} if self.firmware else {}
        )
        return GcsSpec(
            uplink=spec.uplink,
            downlink=spec.downlink,
            truth=world_topics(self.world).truth,
            period=1.0 / self.rate,
            obstacles=tuple(o.name for o in self.world.obstacles),
            **slack,
        )

    def _with_ground_station(self, environment: LocalEnvironment, autopilot: Node) -> PX4Node:
        """The node: ``autopilot`` (stopped if this fails) and a ground station for it."""
        try:
            node = InProcessFirmwareComponent(
                ground_station(self.gcs_spec(), PX4Procedure(), f"{self.name}.gcs"),
                name=f"{self.name}.gcs",
            ).start(environment)
        except BaseException:
            autopilot.stop()
            raise
        return PX4Node(self.name, node, autopilot, self)

    def _start_sitl(self, environment: LocalEnvironment, spec: AutopilotSpec) -> PX4Node:
        assert self.firmware is not None
        group = start_sitl(
            self.firmware,
            resolve(self.placement, self.fidelity),
            environment,
            name=self.name,
            topics=spec.topics,
            home_alt=self.world.home.alt,
            period=sitl_period(self.world),
            wire=spec.wire,
            uplink=spec.uplink,
            downlink=spec.downlink,
            params=self.sitl_params(),
        )
        return self._with_ground_station(environment, group)


class PX4Simulation(ScenarioSimulation):
    """A running PX4 simulation: ``firmware`` flies missions, ``world`` is the physics node."""

    def __init__(
        self, simulation: ProcessSimulation, firmware_id: NodeId[PX4Node], world_id: NodeId[Node]
    ) -> None:
        super().__init__(simulation)
        self.firmware: PX4Node = simulation.get(firmware_id)
        self.world: Node = simulation.get(world_id)

    @property
    def home(self) -> Home:
        """Where the autopilot's home is (latitude, longitude, altitude AMSL): the origin."""
        return self.firmware.component.world.home

    def trace_options(self) -> TraceOptions:
        """What a recorder of this simulation should know (types, decoders, Foxglove channels)."""
        return self.firmware.component.trace_options()

    def flight_logs(self) -> list[Path]:
        """Real PX4's ULog files so far (``log/**/*.ulg``; Flight Review reads them).

        From a container they are copied into the run directory first. Empty for the
        built-in autopilot. A log is complete once PX4 has disarmed (it logs from boot
        until disarm).
        """
        return self.firmware.flight_logs(self.run_dir / "px4-ulog")


class PX4(Scenario[PX4Simulation]):
    """A Simulator with the quadrotor world and PX4 already added (the paper's ``px4.PX4``).

    ``fidelity`` picks the models ("low": point mass; "medium": MuJoCo; "high": MuJoCo at a
    finer step, ``HIGH_FIDELITY_WORLD``, unless ``world`` is given); ``placement`` where the
    world and the autopilot run (a registered name such as ``"in-process"``, ``"process"``
    or ``"docker"``; None: this process at low fidelity, local processes above).
    ``firmware`` picks the autopilot: None for the built-in one, ``px4.SITL(binary=...)``
    for real PX4 SITL (run where the placement runs programs: a local process, or a
    container of its image) flying the MuJoCo world, which then runs in this process at
    PX4's 250 Hz sensor rate. ``seed`` fixes every random source of the world; ``realtime``
    paces the simulation to wall time (for external ground stations). More components
    (injectors, monitors) can be added with ``add`` before ``start``.
    """

    def __init__(
        self,
        world: WorldConfig | None = None,
        *,
        fidelity: Fidelity = "low",
        placement: str | Placement | None = None,
        seed: int = 0,
        realtime: float | None = None,
        geofence: Geofence | None = None,
        params: dict[str, float] | None = None,
        telemetry_rate: float | None = None,
        autopilot_topics: Topics | None = None,
        run_dir: str | None = None,
        firmware: SITL | None = None,
    ) -> None:
        check_fidelity(fidelity)
        world = world if world is not None else default_world(fidelity)
        if not isinstance(world, WorldConfig):
            raise ConfigurationError("world", world, "a px4.WorldConfig")
        if firmware is not None and isinstance(firmware, SITL):
            world = dataclasses.replace(world, period=sitl_period(world))
        self._firmware = PX4Component(
            world,
            fidelity,
            geofence=geofence or Geofence(),
            params=dict(params or {}),
            telemetry_rate=telemetry_rate,
            topics=autopilot_topics,
            placement=placement,
            firmware=firmware,
        )
        super().__init__(
            fidelity=fidelity, placement=placement, seed=seed, realtime=realtime, run_dir=run_dir
        )
        self.world = world
        # With real PX4 the world is its simulator, beside PX4's bridge in this process (as
        # Gazebo is PX4's): one lockstep exchange per 4 ms step instead of two.
        self.world_placement: Placement = (
            resolve("in-process", fidelity) if firmware is not None else self.placement
        )
        self.world_id: NodeId[Node] = self._add_own(
            WorldComponent(
                world, fidelity, placement=self.world_placement, wire=self._firmware.spec.wire
            )
        )
        self.firmware_id: NodeId[PX4Node] = self._add_own(self._firmware, anchor=True)

    @property
    def firmware(self) -> SITL | None:
        """Real PX4 SITL when it is the autopilot, None for the built-in one."""
        return self._firmware.firmware

    @property
    def autopilot_topics(self) -> Topics:
        """The topics the autopilot reads its sensors from."""
        return self._firmware.topics or world_topics(self.world)

    @property
    def wire(self) -> Wire:
        """How sensor payloads travel between world and autopilot (an injector must match)."""
        return self._firmware.spec.wire

    def inject_faults(
        self, sensor: str, models: Sequence[Model], *, name: str | None = None
    ) -> InjectorComponent:
        """Put an injector with ``models`` on ``sensor`` (see
        [`multicosim.attacks.inject`][multicosim.attacks.inject]).

        The autopilot reads the sensor from ``<topic>/attacked``, which the injector fills
        from the world's topic; the injector runs where the world does.
        """
        from ..attacks import InjectorConfig, add_injector, canonical
        from . import injectable  # noqa: F401 - registers PX4's sensors

        sensor = canonical("px4", sensor)
        source = getattr(world_topics(self.world), sensor)
        if getattr(self.autopilot_topics, sensor) != source:
            raise ConfigurationError(
                "sensor", sensor, "a sensor without an injector (combine models in one)"
            )
        config = InjectorConfig(
            vehicle="px4",
            sensor=sensor,
            source=source,
            target=f"{source}/attacked",
            period=LOW_PERIOD if self.fidelity == "low" else self.world.period,
            models=tuple(models),
            # The world's wire: what the scenario's world and autopilot exchange.
            wire=self.wire,
        )
        component = add_injector(
            self, config, name=name or f"{sensor}-injector", placement=self.world_placement
        )
        self.read_sensor_from(sensor, config.target)
        return component

    def read_sensor_from(self, sensor: str, topic: str) -> None:
        """Have the autopilot read ``sensor`` (imu, mag, baro, gps) from ``topic`` instead.

        Before start; an injector then fills ``topic`` from the world's topic.
        """
        if sensor not in ("imu", "mag", "baro", "gps"):
            raise ConfigurationError("sensor", sensor, "one of 'imu', 'mag', 'baro', 'gps'")
        topics = Topics(**{**msgspec.structs.asdict(self.autopilot_topics), sensor: topic})
        self._firmware = dataclasses.replace(self._firmware, topics=topics)
        self.replace(self.firmware_id, self._firmware)

    def start(self) -> PX4Simulation:
        """Start the world and PX4 (and anything added); return the simulation."""
        return PX4Simulation(self._start_simulation(), self.firmware_id, self.world_id)
