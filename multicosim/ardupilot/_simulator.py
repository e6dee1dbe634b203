"""The paper's API for ArduPilot: ``ArduCopter`` and ``ArduRover`` Simulators and their simulation.

========  ==========================================  ========================================
fidelity  world                                       ArduPilot
========  ==========================================  ========================================
medium    MuJoCo, one 2.5 ms step per physics frame   real SITL: a local process (the
          (400 Hz, ArduPilot's loop rate)             ``process`` placement, the default) or
high      MuJoCo at 0.5 ms, five steps per frame,     a container of its image on the
          more solver iterations                      simulation's network (``docker``)
========  ==========================================  ========================================

The world and ArduPilot's JSON bridge run in this process in every placement (one lockstep
exchange per physics frame); the ground station behind ``simulation.firmware.send`` too.
There is no low fidelity: ArduPilot flies the MuJoCo world.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError, NodeStartError
from ..core.fidelity import FIRMWARE_FIDELITIES, FirmwareFidelity
from ..core.geo import Home
from ..core.interfaces import Node, NodeId
from ..local import (
    InProcessComponent,
    InProcessFirmwareComponent,
    LocalEnvironment,
    ProcessSimulation,
)
from ..mavlink.gcs import GcsSpec, Procedure, ground_station
from ..mavlink.mission import Configuration, Geofence
from ..mavlink.node import MissionNode
from ..physics.config import WorldConfig
from ..placement import Placement, Scenario, ScenarioSimulation, resolve
from ..placement.firmware import preflight_program
from ..rover import MAX_SPEED
from ._bridge import SERVO_TOPIC, TRUTH_TOPIC
from ._frames import FRAME_RATE, copter_params, rover_params
from .launch import (
    NO_RC_RECEIVER,
    SITL,
    ArduPilotNodes,
    Vehicle,
    check_params,
    image_of,
    start_ardupilot,
)

if TYPE_CHECKING:
    from ..trace import TraceOptions
    from .faults import FaultsComponent

__all__ = [
    "FIRMWARE_FIDELITIES",
    "ArduCopter",
    "ArduPilotComponent",
    "ArduPilotNode",
    "ArduPilotSimulation",
    "ArduRover",
    "Fidelity",
    "boot",
    "default_world",
    "frame_period",
]

Fidelity = FirmwareFidelity
FRAME_PERIOD = 1.0 / FRAME_RATE
BOOT_STEP = 0.05  # s of simulated time between looks at ArduPilot's MAVLink link at start
BOOT_LIMIT = 10.0  # s of simulated time ArduPilot gets to start speaking MAVLink

# Medium: one MuJoCo step per physics frame. High: five, and more solver iterations (the
# rover's contacts get more, as in the rover scenario).
_WORLDS: dict[tuple[Vehicle, Fidelity], WorldConfig] = {
    ("copter", "medium"): WorldConfig(timestep=FRAME_PERIOD, period=FRAME_PERIOD),
    ("copter", "high"): WorldConfig(timestep=0.0005, iterations=100, period=FRAME_PERIOD),
    ("rover", "medium"): WorldConfig(timestep=FRAME_PERIOD, period=FRAME_PERIOD),
    ("rover", "high"): WorldConfig(timestep=0.0005, iterations=200, period=FRAME_PERIOD),
}


def default_world(vehicle: Vehicle, fidelity: Fidelity) -> WorldConfig:
    """The world configuration ``vehicle`` uses at ``fidelity`` unless one is given."""
    return _WORLDS[(vehicle, fidelity)]


def frame_period(world: WorldConfig) -> float:
    """The world's period under ArduPilot: one physics frame (2.5 ms), a whole number of steps.

    ConfigurationError if ``world.timestep`` does not divide it.
    """
    steps = max(1, round(FRAME_PERIOD / world.timestep))
    if abs(steps * world.timestep - FRAME_PERIOD) > 1e-9:
        raise ConfigurationError(
            "world.timestep",
            world.timestep,
            f"a divisor of ArduPilot's {FRAME_PERIOD * 1e3:g} ms physics frame "
            f"({FRAME_RATE} Hz, its loop rate), e.g. 0.0025, 0.00125 or 0.0005",
        )
    return FRAME_PERIOD


def _check_fidelity(fidelity: object) -> None:
    if fidelity not in FIRMWARE_FIDELITIES:
        raise ConfigurationError(
            "fidelity",
            fidelity,
            "'medium' or 'high' (ArduPilot flies the MuJoCo world; there is no low fidelity)",
        )


@dataclasses.dataclass(frozen=True)
class WorldComponent:
    """The MuJoCo world with ``vehicle`` driven by ArduPilot, in this process."""

    world: WorldConfig
    vehicle: Vehicle
    name: str = "world"

    def start(self, environment: LocalEnvironment) -> Node:
        """Build the world (MuJoCo loads here) and schedule it."""
        world, vehicle = self.world, self.vehicle

        def factory() -> Any:
            from ..physics.world import World
            from .vehicles import ArduCopterVehicle, ArduRoverVehicle

            plugin = ArduCopterVehicle() if vehicle == "copter" else ArduRoverVehicle()
            return World(world, plugin)

        return InProcessComponent(factory, self.name).start(environment)


class ArduPilotNode(MissionNode):
    """The ArduPilot firmware node: ``send(Configuration) -> MissionResult`` flies a mission."""

    autopilot_node: ArduPilotNodes
    component: ArduPilotComponent

    @property
    def instance(self) -> int:
        """ArduPilot's instance number (its ports are offset by ten times it)."""
        return self.autopilot_node.instance

    @property
    def firmware_nodes(self) -> ArduPilotNodes:
        """ArduPilot's program and its bridge."""
        return self.autopilot_node

    def flight_logs(self, into: Path) -> list[Path]:
        """ArduPilot's DataFlash logs so far (``logs/*.BIN``; from a container, copied into
        ``into`` first)."""
        return self.autopilot_node.flight_logs(into)

    def check(self, msg: Configuration) -> None:
        """Raise ConfigurationError if ``msg`` cannot be flown (or driven)."""
        super().check(msg)
        if self.component.vehicle == "rover" and msg.cruise_speed >= MAX_SPEED:
            raise ConfigurationError(
                "cruise_speed", msg.cruise_speed, f"below the rover's top speed ({MAX_SPEED:g} m/s)"
            )


@dataclasses.dataclass(frozen=True)
class ArduPilotComponent:
    """ArduPilot SITL with its JSON bridge and a ground station, for any ProcessSimulator.

    ``vehicle`` is ``"copter"`` or ``"rover"``; ``firmware`` where ArduPilot comes from;
    ``world`` where home is (ArduPilot's ``--home``) and what its physics period is;
    ``params`` are set at boot, after the frame's (``_frames``); ``geofence`` bounds
    missions. ArduPilot runs where ``placement`` runs programs (None: a local process; a
    container of its image with ``"docker"``); its bridge and the ground station run in
    this process.
    """

    vehicle: Vehicle
    firmware: SITL
    world: WorldConfig
    name: str = "ardupilot"
    geofence: Geofence = dataclasses.field(default_factory=Geofence)
    params: dict[str, float] = dataclasses.field(default_factory=dict)
    telemetry_rate: float = 20.0
    placement: str | Placement | None = None

    def __post_init__(self) -> None:
        if self.vehicle not in ("copter", "rover"):
            raise ConfigurationError("vehicle", self.vehicle, "'copter' or 'rover'")
        if not isinstance(self.firmware, SITL):
            raise ConfigurationError("firmware", self.firmware, "a multicosim.ardupilot.SITL")
        if not isinstance(self.world, WorldConfig):
            raise ConfigurationError("world", self.world, "a multicosim.physics.WorldConfig")
        if not isinstance(self.geofence, Geofence):
            raise ConfigurationError("geofence", self.geofence, "a px4.Geofence")
        rate = self.telemetry_rate
        if isinstance(rate, bool) or not isinstance(rate, int | float) or not 10 <= rate <= 100:
            raise ConfigurationError("telemetry_rate", rate, "10 to 100 Hz")
        check_params(self.params)
        self.firmware.check(self.vehicle)
        frame_period(self.world)
        self.required_images()

    def required_images(self) -> tuple[str, ...]:
        """The images its placement needs (ConfigurationError if it cannot run ArduPilot)."""
        return preflight_program(
            resolve(self.placement, "medium"),
            self.name,
            command=self.firmware.directory is not None,
            image=image_of(self.firmware),
            needs="ArduPilot SITL's directory (firmware_dir=...) to run it on this machine, "
            "or an image (image=...) with placement='docker'",
        )

    def boot_params(self) -> dict[str, float]:
        """The parameters ArduPilot boots with: no RC receiver (``NO_RC_RECEIVER``), the
        frame's, then ``params``, the firmware's."""
        if self.vehicle == "copter":
            from ..quadrotor.airframe import NONE_IRIS

            frame = copter_params(NONE_IRIS)
        else:
            frame = rover_params(MAX_SPEED)
        return {**NO_RC_RECEIVER, **frame, **self.params, **self.firmware.params}

    def procedure(self) -> Procedure:
        """How the ground station flies this vehicle."""
        from ._gcs import CopterProcedure, RoverProcedure

        return CopterProcedure() if self.vehicle == "copter" else RoverProcedure()

    @property
    def links(self) -> tuple[str, str]:
        """Its MAVLink topics (uplink, downlink), under its name (``ardupilot/mavlink/up``)."""
        return f"{self.name}/mavlink/up", f"{self.name}/mavlink/down"

    @property
    def topics(self) -> tuple[str, str]:
        """The world's topics it exchanges through its bridge: truth and servo outputs."""
        return self.world.topic("truth", TRUTH_TOPIC), self.world.topic("servos", SERVO_TOPIC)

    def gcs_spec(self) -> GcsSpec:
        """What a ground station flying this ArduPilot needs: its link, the world's truth,
        the telemetry period and ArduPilot's longer preflight."""
        uplink, downlink = self.links
        return GcsSpec(
            uplink=uplink,
            downlink=downlink,
            truth=self.topics[0],
            period=1.0 / self.telemetry_rate,
            obstacles=tuple(o.name for o in self.world.obstacles),
            # ArduPilot's estimator needs its GPS checks and gyro bias learnt (about 40
            # simulated seconds) before it has a position and arms.
            preflight_timeout=180.0,
            dialect="ardupilotmega",
        )

    def trace_options(self, *, member: bool = False, start: Home | None = None) -> TraceOptions:
        """Its trace options: the MAVLink link decoded, the world's truth and ArduPilot's
        outputs typed, Foxglove channels (``member``, ``start``: as a fleet's vehicle, see
        ``mission_trace``)."""
        import dataclasses

        from ..mavlink.trace import mission_trace
        from ._bridge import ServoOutputs

        (uplink, downlink), (truth, servos) = self.links, self.topics
        options = mission_trace(
            vehicle=self.name,
            uplink=uplink,
            downlink=downlink,
            truth=truth,
            home=self.world.home,
            obstacles=self.world.obstacles,
            types={servos: ServoOutputs},
            dialect_name="ardupilotmega",
            member=member,
            start=start,
        )
        # ArduPilot runs its own threads: its runs repeat their verdicts, not their bits.
        return dataclasses.replace(options, deterministic=False)

    def start(self, environment: LocalEnvironment) -> ArduPilotNode:
        """Start ArduPilot and its bridge, then the ground station."""
        name = self.name
        uplink, downlink = self.links
        truth, servos = self.topics
        group = start_ardupilot(
            self.firmware,
            self.vehicle,
            resolve(self.placement, "medium"),
            environment,
            name=name,
            period=frame_period(self.world),
            home=self.world.home,
            params=self.boot_params(),
            truth=truth,
            servos=servos,
            uplink=uplink,
            downlink=downlink,
        )
        try:
            gcs = InProcessFirmwareComponent(
                ground_station(self.gcs_spec(), self.procedure(), f"{name}.gcs"),
                name=f"{name}.gcs",
            ).start(environment)
        except BaseException:
            group.stop()
            raise
        return ArduPilotNode(name, gcs, group, self)


def boot(simulation: ScenarioSimulation, node: ArduPilotNode, limit: float = BOOT_LIMIT) -> None:
    """Run ``simulation`` until ``node``'s ArduPilot has booted: its MAVLink link speaks.

    ArduPilot's first physics step comes while it loads its parameters: left waiting there
    for seconds of wall time (while another simulation runs, say), it hangs in its start-up.
    So a simulation with ArduPilot runs it through its start-up (a few tenths of a simulated
    second) before handing the simulation out. NodeStartError, with its output tail, if it
    has not spoken MAVLink within ``limit`` simulated seconds.
    """
    autopilot = node.firmware_nodes
    bridge = autopilot.bridge
    assert bridge is not None
    deadline = simulation.time + limit
    while not bridge.linked:
        if simulation.time >= deadline:
            process = autopilot.program
            raise NodeStartError(
                node.name,
                f"sent no MAVLink within {limit:g} simulated seconds of its start",
                log_tail=process.log_tail() if process is not None else "",
            )
        simulation.advance(BOOT_STEP)


class ArduPilotSimulation(ScenarioSimulation):
    """A running ArduPilot simulation: ``firmware`` flies missions, ``world`` is the physics."""

    def __init__(
        self,
        simulation: ProcessSimulation,
        firmware_id: NodeId[ArduPilotNode],
        world_id: NodeId[Node],
    ) -> None:
        super().__init__(simulation)
        self.firmware: ArduPilotNode = simulation.get(firmware_id)
        self.world: Node = simulation.get(world_id)

    def boot(self, limit: float = BOOT_LIMIT) -> None:
        """Run the simulation until ArduPilot has booted (see
        [`boot`][multicosim.ardupilot._simulator.ArduPilotSimulation.boot])."""
        boot(self, self.firmware, limit)

    @property
    def home(self) -> Home:
        """Where ArduPilot's home is (latitude, longitude, altitude AMSL): the world's origin."""
        return self.firmware.component.world.home

    def trace_options(self) -> TraceOptions:
        """What a recorder of this simulation should know: the MAVLink link decoded, the
        world's truth and ArduPilot's outputs typed, Foxglove channels."""
        return self.firmware.component.trace_options()

    def flight_logs(self) -> list[Path]:
        """ArduPilot's DataFlash logs so far (``logs/*.BIN``; MAVExplorer and UAV Log Viewer
        read them). From a container they are copied into the run directory first."""
        return self.firmware.flight_logs(self.run_dir / "ardupilot-logs")


class _ArduPilotSimulator(Scenario[ArduPilotSimulation]):
    """A Simulator with the MuJoCo world and ArduPilot already added."""

    vehicle: Vehicle = "copter"

    def __init__(
        self,
        world: WorldConfig | None = None,
        *,
        fidelity: Fidelity = "medium",
        firmware_dir: str | None = None,
        image: str | None = None,
        firmware: SITL | None = None,
        placement: str | Placement | None = None,
        seed: int = 0,
        params: dict[str, float] | None = None,
        geofence: Geofence | None = None,
        telemetry_rate: float = 20.0,
        realtime: float | None = None,
        run_dir: str | None = None,
    ) -> None:
        _check_fidelity(fidelity)
        if firmware is None:
            firmware = SITL(directory=firmware_dir, image=image)
        elif firmware_dir is not None or image is not None:
            raise ConfigurationError(
                "firmware", firmware, "either firmware=SITL(...) or firmware_dir/image, not both"
            )
        if not isinstance(firmware, SITL):
            raise ConfigurationError("firmware", firmware, "a multicosim.ardupilot.SITL")
        world = world if world is not None else default_world(self.vehicle, fidelity)
        if not isinstance(world, WorldConfig):
            raise ConfigurationError("world", world, "a multicosim.physics.WorldConfig")
        world = dataclasses.replace(world, period=frame_period(world))
        self._firmware = ArduPilotComponent(
            self.vehicle,
            firmware,
            world,
            geofence=geofence or Geofence(),
            params=dict(params or {}),
            telemetry_rate=telemetry_rate,
            placement=placement,
        )
        super().__init__(
            fidelity=fidelity, placement=placement, seed=seed, realtime=realtime, run_dir=run_dir
        )
        self.world = world
        self.world_id: NodeId[Node] = self._add_own(WorldComponent(world, self.vehicle))
        self.firmware_id: NodeId[ArduPilotNode] = self._add_own(self._firmware, anchor=True)

    @property
    def firmware(self) -> SITL:
        """Where ArduPilot comes from."""
        return self._firmware.firmware

    @property
    def params(self) -> dict[str, float]:
        """The parameters given to ArduPilot (besides the frame's)."""
        return dict(self._firmware.params)

    def inject_faults(
        self, sensor: str, models: Any, *, name: str | None = None
    ) -> FaultsComponent:
        """Have ArduPilot simulate ``models`` on ``sensor`` (``multicosim.attacks.inject``).

        The models map onto ArduPilot's own simulated sensor faults (its ``SIM_GPS_*`` and
        ``SIM_BARO_*`` parameters), set over MAVLink when each model's window opens.
        """
        from .faults import FaultsComponent, FaultsConfig

        config = FaultsConfig(
            sensor=sensor,
            models=tuple(models),
            home=self.world.home,
            uplink=self._firmware.links[0],
            downlink=self._firmware.links[1],
        )
        component = FaultsComponent(config, name=name or f"{config.sensor}-faults")
        self.add(component)
        return component

    def start(self) -> ArduPilotSimulation:
        """Start the world and ArduPilot (and anything added); return the simulation."""
        simulation = ArduPilotSimulation(self._start_simulation(), self.firmware_id, self.world_id)
        try:
            simulation.boot()
        except BaseException:
            simulation.stop()
            raise
        return simulation

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(fidelity={self.fidelity!r}, "
            f"placement={self.placement.name!r}, firmware={self.firmware!r})"
        )


class ArduCopter(_ArduPilotSimulator):
    """ArduCopter SITL flying our quadrotor (PX4's ``none_iris`` airframe) as its quad X.

    ``ardupilot.ArduCopter(world, fidelity="medium", firmware_dir=PATH)``: ``world`` a
    [`WorldConfig`][multicosim.physics.WorldConfig] (None: the fidelity's, see ``default_world``),
    whose timestep must divide ArduPilot's 2.5 ms frame; ``firmware_dir`` ArduPilot SITL's
    directory (``bin/arducopter``, ``params/copter.parm``), or ``image`` (``backend="docker"``)
    or ``firmware=SITL(...)``; ``params`` ArduPilot parameters set at boot; ``seed`` fixes
    every random source of the world. ``start()`` gives an
    [`ArduPilotSimulation`][multicosim.ardupilot._simulator.ArduPilotSimulation].
    """

    vehicle: Vehicle = "copter"


class ArduRover(_ArduPilotSimulator):
    """ArduRover SITL driving our Ackermann rover (steering and throttle outputs).

    The same arguments as [`ArduCopter`][multicosim.ardupilot._simulator.ArduCopter];
    ``firmware_dir`` needs ``bin/ardurover`` and ``params/rover.parm``.
    """

    vehicle: Vehicle = "rover"
