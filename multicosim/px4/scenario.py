"""The paper's PX4 classes: ``PX4Component``, the ``PX4`` simulator and its simulation.

Fidelity picks the models, the backend where they run (the mission logic is the same code):

=========  ==========================  ====================================================
fidelity   world                       ``backend="process"``
=========  ==========================  ====================================================
low        point mass, ideal sensors   world, autopilot and ground station in this process
medium     MJCF quadrotor in MuJoCo    world and autopilot as two local processes stepped
           (2 ms step), noisy sensors  in lockstep, exchanging MAVLink HIL frames; ground
                                       station in this process
high       as medium, 0.5 ms step and  as medium
           twice the solver iterations
=========  ==========================  ====================================================

``backend="docker"`` runs the world and the autopilot, at any fidelity, as containers of
``multicosim.docker.RUNTIME_IMAGE`` on the simulation's network, exchanging what the process
backend exchanges at that fidelity (native messages at low, MAVLink HIL frames above); the
ground station stays in this process. A seed gives the same flight on both backends at the
same fidelity.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import msgspec

from ..core.errors import ConfigurationError
from ..core.fidelity import BACKENDS, Backend, Fidelity, check_fidelity
from ..core.interfaces import Component, Node, NodeId
from ..local import (
    InProcessComponent,
    InProcessFirmwareComponent,
    LocalEnvironment,
    ProcessComponent,
    ProcessSimulation,
    ProcessSimulator,
    ScenarioSimulation,
    participant_command,
    required_images,
)
from ..mavlink.gcs import GcsSpec, ground_station
from ..mavlink.hil import Wire
from ..mavlink.mission import (
    Geofence,
    Home,
    MuJoCo,
    Topics,
    world_topics,
)
from ..mavlink.node import MissionNode
from .autopilot.firmware import Autopilot, AutopilotSpec
from .sitl import SENSOR_RATE, SITL, start_sitl
from .world import WorldSpec, world

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..attacks import InjectorComponent, Model
    from ..docker import ContainerEnvironment, ContainerSimulator
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
HIGH_FIDELITY_WORLD = MuJoCo(timestep=0.0005, iterations=100)


def default_world(fidelity: Fidelity) -> MuJoCo:
    """The world configuration a fidelity level uses unless one is given."""
    return HIGH_FIDELITY_WORLD if fidelity == "high" else MuJoCo()


def sitl_period(world: MuJoCo) -> float:
    """The world period real PX4 gets its sensors at: the timestep multiple nearest 250 Hz."""
    steps = max(1, round(1.0 / SENSOR_RATE / world.timestep))
    return round(world.timestep * steps, 9)


def _check_image(image: object) -> None:
    if image is not None and (not isinstance(image, str) or not image.strip()):
        raise ConfigurationError("image", image, "None or a local image name such as 'name:tag'")


def _in_process(fidelity: str, process: bool | None) -> bool:
    # Also picks the wire: native messages in-process, MAVLink HIL frames between processes.
    # A container (``image``) keeps the wire of its fidelity, so that a seed gives the same
    # flight in a container as on the process backend.
    return not (process if process is not None else fidelity != "low")


def _participant_command(factory: str, spec: msgspec.Struct) -> list[str]:
    return [sys.executable, "-m", *participant_command(factory, spec)]


def _start_participant(
    environment: LocalEnvironment, name: str, factory: str, spec: msgspec.Struct, image: str | None
) -> Node:
    """Start participant ``factory(spec)`` as a local process, or a container of ``image``."""
    if image is None:
        return ProcessComponent(_participant_command(factory, spec), name=name).start(environment)
    from ..docker import ContainerComponent, ContainerEnvironment

    if not isinstance(environment, ContainerEnvironment):
        raise ConfigurationError(
            "image", image, "None outside a ContainerSimulator (containers need its network)"
        )
    return ContainerComponent(image, participant_command(factory, spec), name=name).start(
        environment
    )


@dataclasses.dataclass(frozen=True)
class WorldComponent:
    """The quadrotor world as a component (point mass at low fidelity, MuJoCo above).

    It runs in this process at low fidelity and as a local process above (``process``
    overrides that), or as a container of ``image`` when one is given (in a
    ContainerSimulator).
    """

    world: MuJoCo = dataclasses.field(default_factory=MuJoCo)
    fidelity: Fidelity = "low"
    name: str = "world"
    process: bool | None = None
    image: str | None = None

    def __post_init__(self) -> None:
        check_fidelity(self.fidelity)
        if not isinstance(self.world, MuJoCo):
            raise ConfigurationError("world", self.world, "a px4.MuJoCo configuration")
        _check_image(self.image)

    def required_images(self) -> tuple[str, ...]:
        """The image it runs in, if any (checked before a ContainerSimulator starts)."""
        return (self.image,) if self.image is not None else ()

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
        """Start the world in this process, as a process or as a container."""
        spec = self.spec
        if self.image is None and _in_process(self.fidelity, self.process):
            return InProcessComponent(lambda: world(spec), self.name).start(environment)
        return _start_participant(
            environment, self.name, "multicosim.px4.world:world", spec, self.image
        )


class PX4Node(MissionNode):
    """The PX4 firmware node: ``send(Configuration) -> MissionResult`` flies a mission."""

    _component: PX4Component

    @property
    def autopilot(self) -> Autopilot | None:
        """The live autopilot object when it runs in this process (for inspection)."""
        return getattr(self._autopilot, "participant", None)


@dataclasses.dataclass(frozen=True)
class PX4Component:
    """PX4 plus its ground station, for any ProcessSimulator (the paper's ``PX4Component``).

    ``firmware`` picks the autopilot: None for the built-in PX4-compatible one, or a
    :class:`~multicosim.px4.SITL` for real PX4 SITL flying the world. ``world`` tells it
    where home is and which topics carry the sensors (``topics`` overrides the autopilot's
    side only, to read from an injector); ``params`` sets PX4 parameters (``MPC_XY_CRUISE``,
    ``NAV_ACC_RAD``, ...); ``geofence`` bounds missions. The built-in autopilot runs where
    WorldComponent's world does (``process``, ``image``); real PX4 runs as a process, or as
    a container of ``image`` in a ContainerSimulator. The ground station always runs in
    this process.
    """

    world: MuJoCo = dataclasses.field(default_factory=MuJoCo)
    fidelity: Fidelity = "low"
    name: str = "px4"
    geofence: Geofence = dataclasses.field(default_factory=Geofence)
    params: dict[str, float] = dataclasses.field(default_factory=dict)
    telemetry_rate: float | None = None
    topics: Topics | None = None
    process: bool | None = None
    image: str | None = None
    firmware: SITL | None = None

    def required_images(self) -> tuple[str, ...]:
        """The image the autopilot runs in, if any (checked before a ContainerSimulator starts)."""
        if self.firmware is not None:
            return (self.firmware.image,) if self.firmware.image is not None else ()
        return (self.image,) if self.image is not None else ()

    @property
    def rate(self) -> float:
        """Telemetry (and trajectory sampling) rate: 10 Hz at low fidelity, else 20 Hz."""
        if self.telemetry_rate is not None:
            return self.telemetry_rate
        return 10.0 if self.fidelity == "low" else 20.0

    def __post_init__(self) -> None:
        check_fidelity(self.fidelity)
        if not isinstance(self.world, MuJoCo):
            raise ConfigurationError("world", self.world, "a px4.MuJoCo configuration")
        if not isinstance(self.geofence, Geofence):
            raise ConfigurationError("geofence", self.geofence, "a px4.Geofence")
        _check_image(self.image)
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
            wire="native" if _in_process(self.fidelity, self.process) else "mavlink",
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

    def start(self, environment: LocalEnvironment) -> PX4Node:
        """Start the autopilot (in-process, a process or a container) and the ground station."""
        spec = self.spec
        if self.firmware is not None:
            return self._start_sitl(environment, spec)
        if self.image is None and _in_process(self.fidelity, self.process):
            autopilot: Node = InProcessComponent(lambda: Autopilot(spec), self.name).start(
                environment
            )
        else:
            autopilot = _start_participant(
                environment,
                self.name,
                "multicosim.px4.autopilot.firmware:autopilot",
                spec,
                self.image,
            )
        return self._with_ground_station(environment, spec, autopilot)

    def _with_ground_station(
        self, environment: LocalEnvironment, spec: AutopilotSpec, autopilot: Node, **gcs: Any
    ) -> PX4Node:
        """The node: ``autopilot`` (stopped if this fails) and a ground station for it."""
        try:
            gcs_spec = GcsSpec(
                uplink=spec.uplink,
                downlink=spec.downlink,
                truth=world_topics(self.world).truth,
                period=1.0 / self.rate,
                **gcs,
            )
            node = InProcessFirmwareComponent(
                ground_station(gcs_spec, f"{self.name}.gcs"), name=f"{self.name}.gcs"
            ).start(environment)
        except BaseException:
            autopilot.stop()
            raise
        return PX4Node(self.name, node, autopilot, self)

    def _start_sitl(self, environment: LocalEnvironment, spec: AutopilotSpec) -> PX4Node:
        assert self.firmware is not None
        topics = spec.topics
        group = start_sitl(
            self.firmware,
            environment,
            name=self.name,
            topics=topics,
            period=sitl_period(self.world),
            wire=spec.wire,
            uplink=spec.uplink,
            downlink=spec.downlink,
            params=self.sitl_params(),
        )
        # PX4's estimator needs its GPS checks passed (about 10 s) before it arms; its
        # MAVLink thread answers in wall time, so commands get more slack.
        return self._with_ground_station(
            environment, spec, group, preflight_timeout=120.0, command_timeout=3.0
        )


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
        return self.firmware._component.world.home

    def trace_options(self) -> TraceOptions:
        """What a recorder of this simulation should know (types, decoders, Foxglove channels)."""
        from .trace import trace_options

        component = self.firmware._component
        return trace_options(component.spec, component.world)

    def flight_logs(self) -> list[Path]:
        """Real PX4's ULog files so far (``log/**/*.ulg``; Flight Review reads them).

        From a container they are copied into the run directory first. Empty for the
        built-in autopilot. A log is complete once PX4 has disarmed (it logs from boot
        until disarm).
        """
        nodes = getattr(self.firmware._autopilot, "flight_logs", None)
        if nodes is None:
            return []
        logs: list[Path] = nodes(self.simulation.run_dir / "px4-ulog")
        return logs


class PX4:
    """A Simulator with the quadrotor world and PX4 already added (the paper's ``px4.PX4``).

    ``fidelity`` picks the models ("low": point mass; "medium": MuJoCo; "high": MuJoCo at a
    finer step, ``HIGH_FIDELITY_WORLD``, unless ``world`` is given); ``backend`` where the
    world and the autopilot run ("process": in this process at low fidelity, else local
    processes; "docker": containers of ``multicosim.docker.RUNTIME_IMAGE``, built with
    ``multicosim images build``). ``firmware`` picks the autopilot: None for the
    built-in one, ``px4.SITL(binary=...)`` for real PX4 SITL (a process on the process
    backend, a container on the docker backend) flying the MuJoCo world, which then runs
    in this process (or its container) at PX4's 250 Hz sensor rate. ``seed`` fixes every
    random source of the world; ``realtime`` paces the simulation to wall time (for external
    ground stations). More components (injectors, monitors) can be added with ``add``
    before ``start``.
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
        firmware: SITL | None = None,
    ) -> None:
        check_fidelity(fidelity)
        world = world if world is not None else default_world(fidelity)
        if not isinstance(world, MuJoCo):
            raise ConfigurationError("world", world, "a px4.MuJoCo configuration")
        if firmware is not None and isinstance(firmware, SITL):
            if backend == "process" and firmware.binary is None:
                raise ConfigurationError(
                    "firmware",
                    firmware,
                    "px4.SITL(binary=...) on the process backend (an image runs on "
                    "backend='docker')",
                )
            world = dataclasses.replace(world, period=sitl_period(world))
        if backend not in BACKENDS:
            raise ConfigurationError(
                "backend",
                backend,
                f"one of {BACKENDS} (a real PX4 SITL image: see multicosim.px4.real)",
            )
        self.world = world
        self.fidelity: Fidelity = fidelity
        self.backend: Backend = backend
        self._sim: ProcessSimulator | ContainerSimulator
        image: str | None = None
        if backend == "docker":
            from ..docker import RUNTIME_IMAGE, ContainerSimulator

            self._sim = ContainerSimulator(seed=seed, realtime=realtime, run_dir=run_dir)
            image = RUNTIME_IMAGE
        else:
            self._sim = ProcessSimulator(seed=seed, realtime=realtime, run_dir=run_dir)
        # With real PX4 as a process, the world is its simulator in this process (as Gazebo
        # is PX4's): one lockstep exchange per 4 ms step instead of two.
        process = False if firmware is not None and backend == "process" else None
        self.world_id: NodeId[Node] = self._sim.add(
            WorldComponent(world, fidelity, image=image, process=process)
        )
        self._firmware = PX4Component(
            world,
            fidelity,
            geofence=geofence or Geofence(),
            params=dict(params or {}),
            telemetry_rate=telemetry_rate,
            topics=autopilot_topics,
            image=image if firmware is None else None,
            process=process,
            firmware=firmware,
        )
        self.firmware_id: NodeId[PX4Node] = self._sim.add(self._firmware)

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
        """How sensor payloads travel between world and autopilot (an injector must match).

        Native Structs at low fidelity, MAVLink HIL frames above, on both backends.
        """
        return self._firmware.spec.wire

    def inject_faults(
        self, sensor: str, models: Sequence[Model], *, name: str | None = None
    ) -> InjectorComponent:
        """Put an injector with ``models`` on ``sensor`` (see :func:`multicosim.attacks.inject`).

        The autopilot reads the sensor from ``<topic>/attacked``, which the injector fills
        from the world's topic.
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
            # The world's wire: what the scenario's world and autopilot exchange (Structs at
            # low fidelity, on either backend; MAVLink frames between processes above).
            wire=self.wire,
        )
        # Where the world runs: in this process at low fidelity, and as real PX4's simulator.
        in_process = self.backend == "process" and (
            self.fidelity == "low" or self.firmware is not None
        )
        component = add_injector(
            self,
            config,
            name=name or f"{sensor}-injector",
            in_process=in_process,
            backend=self.backend,
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
        self._sim.replace(self.firmware_id, self._firmware)

    def add(self, component: Component[ContainerEnvironment, Any]) -> NodeId[Any]:
        """Add another component (an injector, a monitor) to the simulation.

        Any component runs on the docker backend; container components need it.
        """
        if self.backend != "docker" and required_images(component):
            raise ConfigurationError(
                "component",
                component,
                "a component of the process backend (containers need backend='docker')",
            )
        # Typed for the docker backend, which takes every component; the process backend
        # gets no container component (refused above).
        # Before the autopilot: what an injector publishes reaches it in the same instant.
        return self._sim.add(
            cast("Component[LocalEnvironment, Any]", component), before=self.firmware_id
        )

    def start(self) -> PX4Simulation:
        """Start the world and PX4 (and anything added); return the simulation."""
        sitl = self._firmware.firmware
        if sitl is not None and self.backend == "docker" and sitl.image is None:
            # Real PX4 in a container: its image is built from the binary's bundle (once;
            # a build whose inputs did not change is skipped).
            from ..docker import build_px4

            image = build_px4(sitl.bundle)
            self._firmware = dataclasses.replace(
                self._firmware, firmware=dataclasses.replace(sitl, image=image)
            )
            self._sim.replace(self.firmware_id, self._firmware)
        return PX4Simulation(self._sim.start(), self.firmware_id, self.world_id)
