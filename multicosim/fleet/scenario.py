"""The fleet scenario: several vehicles in one world, each flown by the autopilot chosen for it,
on one clock; their missions flown at once; the encounter measured.

=========  ===============================================  ==================================
fidelity   world                                            default placement
=========  ===============================================  ==================================
low        a point mass per vehicle (each a world of its    ``in-process``
           own), collisions found analytically
medium     one MuJoCo world holding every quadrotor,        ``process``: the world and each
           collisions from MuJoCo's contacts                built-in autopilot a process
high       as medium, the finer step                        as medium
=========  ===============================================  ==================================

Real PX4 flies a vehicle at medium and high (``firmware=px4.SITL(...)``): one instance each
(``px4 -i N``, its MAV_SYS_ID N + 1), numbered as PX4's multi-vehicle start script numbers
them; the world then runs in this process beside their bridges.
"""

from __future__ import annotations

import dataclasses
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import msgspec

from ..ardupilot import SITL as ArduPilotSITL
from ..ardupilot import ArduPilotComponent, boot, frame_period
from ..ardupilot import default_world as ardupilot_world
from ..core.errors import ConfigurationError
from ..core.fidelity import Fidelity, check_fidelity
from ..core.geo import Home, LocalProjection
from ..core.interfaces import Node, NodeId
from ..local import InProcessComponent, InProcessFirmwareComponent, InProcessNode
from ..mavlink.flights import fly_together
from ..mavlink.gcs import GcsSpec, GroundStation, Procedure
from ..mavlink.mission import Configuration, MissionResult
from ..physics.config import WorldConfig
from ..physics.encounter import NMAC, PairSample, WellClear, check_volume
from ..physics.fleet import Pose, member_names, resolve_pose
from ..placement import ParticipantProgram, Placement, Scenario, ScenarioSimulation, resolve
from ..px4.procedure import PX4Procedure
from ..px4.scenario import LOW_PERIOD, PX4Component, default_world, sitl_period
from ..px4.sitl import SENSOR_RATE, SITL
from ..px4.standalone import StandaloneAutopilot, StandalonePX4, paced_params
from ..px4.world import WorldSpec
from ..quadrotor.airframe import NONE_IRIS
from ..quadrotor.topics import SENSORS, Topics, world_topics
from ..rover import REACH as ROVER_REACH
from ..runtime.serve import Firmware
from .monitor import EncounterMonitor, pair_topic
from .results import FleetMissions, FleetResult, pairs_of
from .world import Body, FleetWorldSpec

if TYPE_CHECKING:
    from ..attacks import InjectorComponent
    from ..attacks.models import Model
    from ..local import ProcessSimulation
    from ..runtime.context import FirmwareContext
    from ..trace import TraceOptions

__all__ = ["ArduPilotVehicle", "Fleet", "FleetFlights", "FleetSimulation", "Member", "PX4Vehicle"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class PX4Vehicle:
    """A quadrotor of the fleet flown by PX4: the built-in autopilot (``firmware`` None) or
    real PX4 SITL (a ``px4.SITL``), from ``start``, with PX4 ``params`` and ``placement``
    for its autopilot (None: the fleet's)."""

    start: Pose = dataclasses.field(default_factory=Pose)
    firmware: SITL | None = None
    params: Mapping[str, float] = dataclasses.field(default_factory=dict)
    placement: str | Placement | None = None
    own_links: bool = False
    """On PX4's usual MAVLink ports for its instance N (QGroundControl on UDP 14550, MAVSDK on
    14540 + N, MAV_SYS_ID N + 1), for a ground station of one's own; ``fly`` does not fly
    it. Real PX4 claims N as ``px4 -i N`` does; the built-in autopilot claims it likewise."""

    def __post_init__(self) -> None:
        if not isinstance(self.start, Pose):
            raise ConfigurationError("start", self.start, "a physics.Pose")
        if self.firmware is not None and not isinstance(self.firmware, SITL):
            raise ConfigurationError(
                "firmware", self.firmware, "None (the built-in autopilot) or a px4.SITL"
            )


@dataclasses.dataclass(frozen=True, kw_only=True)
class ArduPilotVehicle:
    """A vehicle of the fleet flown by real ArduPilot SITL: ArduCopter flying our quadrotor
    as its quad X (``kind="copter"``) or ArduRover driving our rover (``"rover"``), from
    ``start``, with ArduPilot ``params`` and ``placement`` for it (None: a local process).

    Each is one instance (``-I N``: its ports offset by 10 N, SYSID_THISMAV N + 1), as
    ArduPilot's multi-vehicle SITL numbers them.
    """

    firmware: ArduPilotSITL
    kind: Literal["copter", "rover"] = "copter"
    start: Pose = dataclasses.field(default_factory=Pose)
    params: Mapping[str, float] = dataclasses.field(default_factory=dict)
    placement: str | Placement | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.firmware, ArduPilotSITL):
            raise ConfigurationError("firmware", self.firmware, "an ardupilot.SITL")
        if self.kind not in ("copter", "rover"):
            raise ConfigurationError("kind", self.kind, "'copter' or 'rover'")
        if not isinstance(self.start, Pose):
            raise ConfigurationError("start", self.start, "a physics.Pose")


Member = PX4Vehicle | ArduPilotVehicle
"""A vehicle of a fleet."""


class FleetFlights(msgspec.Struct, frozen=True):
    """The ground station's answer: each vehicle's mission result, by name."""

    results: dict[str, MissionResult]


def fleet_ground_station(
    specs: Mapping[str, tuple[GcsSpec, Procedure]], period: float, name: str = "fleet.gcs"
) -> Firmware[FleetMissions, FleetFlights]:
    """The ground station that flies a mission per vehicle at once (``specs``: each one's
    link and how its autopilot is flown)."""
    specs = dict(specs)

    def handler(msg: FleetMissions, ctx: FirmwareContext) -> FleetFlights:
        unknown = sorted(set(msg.missions) - set(specs))
        if unknown:
            raise ConfigurationError("missions", unknown[0], f"one of {sorted(specs)}")
        runs = {
            vehicle: _flight(*specs[vehicle], config) for vehicle, config in msg.missions.items()
        }
        return FleetFlights(results=fly_together(ctx, runs))

    return Firmware(handler, FleetMissions, period, name)


def _flight(spec: GcsSpec, procedure: Procedure, config: Configuration) -> Any:
    def fly(ctx: Any) -> MissionResult:
        return GroundStation(ctx, spec, procedure).fly(config)

    return fly


class FleetSimulation(ScenarioSimulation):
    """A running fleet: ``fly`` flies a mission per vehicle at once; ``vehicles`` each
    one's node (its own ground station flies it alone with ``send``)."""

    def __init__(
        self,
        simulation: ProcessSimulation,
        vehicles: Mapping[str, NodeId[Any]],
        gcs: NodeId[Any],
        monitor: NodeId[InProcessNode[EncounterMonitor]],
        own_links: frozenset[str] = frozenset(),
        options: TraceOptions | None = None,
    ) -> None:
        super().__init__(simulation)
        self._options = options
        self.vehicles: dict[str, Any] = {n: simulation.get(i) for n, i in vehicles.items()}
        self._flown = sorted(set(vehicles) - own_links)
        self._gcs = simulation.get(gcs)
        self._monitor: EncounterMonitor = simulation.get(monitor).participant

    def fly(
        self, missions: Mapping[str, Configuration], *, timeout: float | None = None
    ) -> FleetResult:
        """Fly ``missions`` (a Configuration per vehicle, by name) at once, on one clock;
        each vehicle's result and the encounter so far. ``timeout`` is the ground station's
        (wall seconds; None: its default), as ``send``'s."""
        for vehicle, config in missions.items():
            if vehicle not in self._flown:
                raise ConfigurationError(
                    "missions",
                    vehicle,
                    f"one of {self._flown} (a vehicle with its own links is not)",
                )
            self.vehicles[vehicle].check(config)
        flights = self._gcs.send(FleetMissions(missions=dict(missions)), timeout=timeout)
        return FleetResult(results=flights.results, encounter=self._monitor.encounter())

    def encounter(self) -> Any:
        """The encounter measured so far ([`Encounter`][multicosim.fleet.Encounter])."""
        return self._monitor.encounter()

    def trace_options(self) -> TraceOptions:
        """Every vehicle's channels under its name, its paths and plan for the plot, the
        pairs' samples; whether its runs repeat bit for bit (not with real firmware)."""
        from ..trace import TraceOptions

        return self._options or TraceOptions()

    def flight_logs(self) -> list[Path]:
        """Each real firmware's flight logs so far (PX4's ULog, ArduPilot's DataFlash), named
        after its vehicle (``alpha-12_00_01.ulg``), in the run directory."""
        out: list[Path] = []
        for name, node in self.vehicles.items():
            logs = getattr(node, "flight_logs", None)  # the nodes of vehicles the fleet flies
            if logs is None:
                continue
            into = self.run_dir / f"{name}-logs"
            for path in logs(into):
                target = self.run_dir / "flight-logs" / f"{name}-{path.name}"
                target.parent.mkdir(exist_ok=True)
                shutil.copyfile(path, target)
                out.append(target)
        return out


class Fleet(Scenario[FleetSimulation]):
    """Several vehicles in one world at ``fidelity``, each flown by the autopilot chosen.

    ``vehicles`` names each vehicle (letters, digits, ``_``, ``-``) and says what it is and
    where it starts (a [`PX4Vehicle`][multicosim.fleet.scenario.PX4Vehicle] or an
    [`ArduPilotVehicle`][multicosim.fleet.scenario.ArduPilotVehicle]); their topics (and trace
    channels) are under their names. ``world`` is the world's configuration (None: the fidelity's;
    with ArduPilot, ArduPilot's), ``well_clear`` the volume the encounter judges (a
    [`WellClear`][multicosim.physics.WellClear] or a preset's name: ``"NMAC"``, ``"DO-365"``,
    ``"ASTM F3442"``). ``placement``, ``seed``, ``realtime`` and ``run_dir`` are every scenario's.
    """

    def __init__(
        self,
        vehicles: Mapping[str, Member],
        *,
        fidelity: Fidelity = "low",
        placement: str | Placement | None = None,
        seed: int = 0,
        world: WorldConfig | None = None,
        well_clear: WellClear | str = NMAC,
        realtime: float | None = None,
        run_dir: str | None = None,
    ) -> None:
        check_fidelity(fidelity)
        names = member_names(vehicles)
        for name in names:
            if not isinstance(vehicles[name], PX4Vehicle | ArduPilotVehicle):
                raise ConfigurationError(
                    f"vehicles[{name!r}]", vehicles[name], "a PX4Vehicle or an ArduPilotVehicle"
                )
        self.volume = check_volume(well_clear)
        arducopters = [n for n in names if isinstance(vehicles[n], ArduPilotVehicle)]
        real = bool(arducopters) or any(
            isinstance(v, PX4Vehicle) and v.firmware is not None for v in vehicles.values()
        )
        if real and fidelity == "low":
            raise ConfigurationError(
                "fidelity",
                fidelity,
                "'medium' or 'high' with real PX4 or ArduPilot (they fly MuJoCo)",
            )
        _check_starts({n: (v.start, _reach(v)) for n, v in vehicles.items()}, world)
        super().__init__(
            fidelity=fidelity, placement=placement, seed=seed, realtime=realtime, run_dir=run_dir
        )
        self.real = real
        """Whether real firmware flies one of its vehicles."""
        self.vehicles = dict(vehicles)
        self.world = self._base_world(world, real)
        # With real firmware the world is its simulator, in this process beside its bridges.
        world_placement = resolve("in-process", self.fidelity) if real else self.placement
        self.world_placement: Placement = world_placement
        """Where the world runs (and the injectors put on its vehicles' sensors)."""
        self.components: dict[str, PX4Component | ArduPilotComponent] = {
            name: self._component(name, vehicle, realtime) for name, vehicle in vehicles.items()
        }
        own = {n for n, v in vehicles.items() if isinstance(v, PX4Vehicle) and v.own_links}
        self.world_ids: list[NodeId[Node]] = []
        if self.fidelity == "low":
            for name, vehicle in self.vehicles.items():
                spec = WorldSpec(
                    model="point_mass",
                    world=self._world_of(name),
                    wire=self._px4(name).spec.wire,
                    point_mass_period=LOW_PERIOD,
                    start=vehicle.start,
                )
                program = ParticipantProgram("multicosim.px4.world:world", spec, f"{name}.world")
                self.world_ids.append(self._add_own(world_placement.participant(program)))
        else:
            px4s = {n: c for n, c in self.components.items() if isinstance(c, PX4Component)}
            spec_m = FleetWorldSpec(
                world=self.world,
                vehicles={n: v.start for n, v in self.vehicles.items()},
                bodies={n: _body(v) for n, v in self.vehicles.items()},
                wires={n: c.spec.wire for n, c in px4s.items()},
                periods={n: c.spec.period for n, c in px4s.items()},
            )
            program = ParticipantProgram("multicosim.fleet.world:world", spec_m, "world")
            self.world_ids.append(self._add_own(world_placement.participant(program)))
        period = LOW_PERIOD if self.fidelity == "low" else self.world.period
        monitor_period = max(period, 0.05)
        truths = {name: self.gcs_specs[name][0].truth for name in names}
        radii = {name: _reach(v) for name, v in vehicles.items()}
        volume = self.volume
        # Two quadrotors' contact spheres touch in MuJoCo; a rover has none (its collisions
        # are found from the states, as every one at low fidelity).
        touching = (
            ()
            if self.fidelity == "low"
            else [n for n in names if _body(vehicles[n]) != "ardurover"]
        )
        self.monitor_id: NodeId[InProcessNode[EncounterMonitor]] = self._add_own(
            InProcessComponent(
                lambda: EncounterMonitor(truths, radii, volume, monitor_period, touching=touching),
                "encounter",
            )
        )
        first = None
        self.vehicle_ids: dict[str, NodeId[Any]] = {}
        for name in self.components:
            node_id = self._add_own(self._added(name), anchor=first is None)
            first = first or node_id
            self.vehicle_ids[name] = node_id
        flown = {n: spec for n, spec in self.gcs_specs.items() if n not in own}
        gcs_period = min((spec.period for spec, _ in flown.values()), default=0.05)
        self.gcs_id = self._add_own(
            InProcessFirmwareComponent(fleet_ground_station(flown, gcs_period), name="fleet.gcs")
        )
        self._arducopters = arducopters

    def _added(self, name: str) -> Any:
        """What the simulation starts for vehicle ``name``: its component, or (its links
        its own) the autopilot with only its links."""
        component = self.components[name]
        vehicle = self.vehicles[name]
        if not (isinstance(vehicle, PX4Vehicle) and vehicle.own_links):
            return component
        px4 = self._px4(name)
        if px4.firmware is None:
            return StandaloneAutopilot(px4)
        return StandalonePX4(
            px4.firmware,
            px4.world,
            px4.sitl_params(),
            resolve(px4.placement, self.fidelity),
            name,
        )

    def inject_faults(
        self, sensor: str, models: Sequence[Model], *, name: str | None = None
    ) -> InjectorComponent:
        """Put an injector with ``models`` on one vehicle's sensor, named
        ``"<vehicle>/<sensor>"`` (``"bravo/gps"``; see
        [`multicosim.attacks.inject`][multicosim.attacks.inject]).

        That vehicle's autopilot (built-in or real PX4) reads the sensor from
        ``<topic>/attacked``, which the injector fills from the world's topic; the injector
        runs where the world does.
        """
        from ..attacks import InjectorConfig, add_injector, canonical
        from ..px4 import injectable  # noqa: F401 - registers PX4's sensors

        member, _, which = sensor.partition("/")
        if member not in self.vehicles or not which:
            raise ConfigurationError(
                "sensor", sensor, f"'<vehicle>/<sensor>', a vehicle of {list(self.vehicles)}"
            )
        vehicle, component = self.vehicles[member], self.components[member]
        if not isinstance(component, PX4Component) or (
            isinstance(vehicle, PX4Vehicle) and vehicle.own_links and vehicle.firmware
        ):
            raise ConfigurationError(
                "sensor",
                sensor,
                "a sensor of a vehicle the fleet flies with PX4 (ArduPilot simulates its "
                "sensors' faults itself: ardupilot.ArduCopter takes them)",
            )
        which = canonical("px4", which)
        reads = component.topics or world_topics(component.world)
        source = getattr(world_topics(component.world), which)
        if getattr(reads, which) != source:
            raise ConfigurationError(
                "sensor", sensor, "a sensor without an injector (combine models in one)"
            )
        spec = component.spec
        config = InjectorConfig(
            vehicle="px4",
            sensor=which,
            source=source,
            target=f"{source}/attacked",
            period=spec.period,
            models=tuple(models),
            wire=spec.wire,  # what this vehicle's world and autopilot exchange
        )
        injector = add_injector(
            self,
            config,
            name=name or f"{member}-{which}-injector",
            placement=self.world_placement,
        )
        topics = Topics(**{**msgspec.structs.asdict(reads), which: config.target})
        self.components[member] = dataclasses.replace(component, topics=topics)
        self.replace(self.vehicle_ids[member], self._added(member))
        return injector

    def _trace_options(self) -> TraceOptions:
        """Each vehicle's channels under its name, from its start; the pairs' samples."""
        from ..trace import TraceOptions, merge_options

        home = self.world.home
        projection = LocalProjection.at(home)
        options = []
        for name, component in self.components.items():
            north, east, up, _ = resolve_pose(self.vehicles[name].start, home)
            lat, lon = projection.reproject(north, east)
            start = Home(lat, lon, home.alt + up)
            options.append(component.trace_options(member=True, start=start))
        names = list(self.vehicles)
        pairs = {pair_topic(a, b): PairSample for a, b in pairs_of(names)}
        options.append(TraceOptions(types=pairs, deterministic=not self.real))
        return merge_options(options)

    def _base_world(self, world: WorldConfig | None, real: bool) -> WorldConfig:
        """The fleet's world: ``world`` or the fidelity's, at ArduPilot's physics frame with
        ArduPilot in it, at real PX4's sensor rate with real PX4."""
        kinds = {_body(v) for v in self.vehicles.values()}
        if kinds & {"arducopter", "ardurover"}:
            fidelity: Any = self.fidelity
            # The rover's world (more solver iterations, for its wheels) with a rover in it.
            kind: Literal["copter", "rover"] = "rover" if "ardurover" in kinds else "copter"
            base = world if world is not None else ardupilot_world(kind, fidelity)
            return dataclasses.replace(base, period=frame_period(base))
        base = world if world is not None else default_world(self.fidelity)
        return dataclasses.replace(base, period=sitl_period(base)) if real else base

    def _member_period(self, vehicle: PX4Vehicle) -> float:
        """A PX4 vehicle's period: its own (real PX4's sensor rate, the built-in autopilot's
        fidelity's period) as a whole number of the world's."""
        period = self.world.period
        if self.fidelity == "low":
            return period
        wanted = (
            1.0 / SENSOR_RATE if vehicle.firmware is not None else default_world("medium").period
        )
        return round(period * max(1, round(wanted / period)), 9)

    def _world_of(self, name: str) -> WorldConfig:
        """The world as vehicle ``name`` sees it: its topics under its name, its period."""
        vehicle = self.vehicles[name]
        if isinstance(vehicle, ArduPilotVehicle):
            topics = {s: f"{name}/{s}" for s in ("truth", "servos")}
            return dataclasses.replace(self.world, sensor_topics=topics)
        return dataclasses.replace(
            self.world,
            sensor_topics={s: f"{name}/{s}" for s in SENSORS},
            period=self._member_period(vehicle),
        )

    def _component(
        self, name: str, vehicle: Member, realtime: float | None
    ) -> PX4Component | ArduPilotComponent:
        placement = vehicle.placement if vehicle.placement is not None else self.placement
        if isinstance(vehicle, ArduPilotVehicle):
            return ArduPilotComponent(
                vehicle.kind,
                vehicle.firmware,
                self._world_of(name),
                name=name,
                params=dict(vehicle.params),
                placement=vehicle.placement,  # ArduPilot's own default: a local process
            )
        # Each built-in autopilot its own system id (the fleet's position of the vehicle, as
        # PX4's instance number gives real PX4 its own) so that a .tlog tells them apart; with
        # its own links, the instance it claims says.
        system_id = (
            {"MAV_SYS_ID": float(list(self.vehicles).index(name) + 1)}
            if vehicle.firmware is None and not vehicle.own_links
            else {}
        )
        return PX4Component(
            self._world_of(name),
            self.fidelity,
            name=name,
            # Wall-clock clients of a paced PX4 get its paced loss timeouts; a user's win.
            params={
                **system_id,
                **(paced_params(realtime or 1.0) if vehicle.own_links else {}),
                **vehicle.params,
            },
            placement=placement,
            firmware=vehicle.firmware,
        )

    def _px4(self, name: str) -> PX4Component:
        component = self.components[name]
        assert isinstance(component, PX4Component)
        return component

    @property
    def gcs_specs(self) -> dict[str, tuple[GcsSpec, Procedure]]:
        """What the fleet's ground station flies each vehicle with: its spec and procedure."""
        out: dict[str, tuple[GcsSpec, Procedure]] = {}
        for name, component in self.components.items():
            if isinstance(component, ArduPilotComponent):
                out[name] = (component.gcs_spec(), component.procedure())
            else:
                out[name] = (component.gcs_spec(), PX4Procedure())
        return out

    def start(self) -> FleetSimulation:
        """Start every vehicle's world and autopilot, the monitor and the ground station;
        run ArduPilot through its start-up."""
        simulation = FleetSimulation(
            self._start_simulation(),
            self.vehicle_ids,
            self.gcs_id,
            self.monitor_id,
            frozenset(
                n for n, v in self.vehicles.items() if isinstance(v, PX4Vehicle) and v.own_links
            ),
            # Now, with every injector's topics in place.
            self._trace_options(),
        )
        try:
            for name in self._arducopters:
                boot(simulation, simulation.vehicles[name])
        except BaseException:
            simulation.stop()
            raise
        return simulation


def _body(vehicle: Member) -> Body:
    if isinstance(vehicle, ArduPilotVehicle):
        return "arducopter" if vehicle.kind == "copter" else "ardurover"
    return "quadrotor"


def _reach(vehicle: Member) -> float:
    """The radius that encloses the vehicle about its reference point (m)."""
    return ROVER_REACH if _body(vehicle) == "ardurover" else NONE_IRIS.radius


def _check_starts(starts: Mapping[str, tuple[Pose, float]], world: WorldConfig | None) -> None:
    """Two vehicles that would start overlapping (the spheres that enclose them) are refused."""
    home = (world or WorldConfig()).home
    placed = {n: (resolve_pose(p, home)[:3], r) for n, (p, r) in starts.items()}
    names = list(placed)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            ((na, ea, ua), ra), ((nb, eb, ub), rb) = placed[a], placed[b]
            distance = ((na - nb) ** 2 + (ea - eb) ** 2 + (ua - ub) ** 2) ** 0.5
            if distance < ra + rb:
                raise ConfigurationError(
                    f"vehicles[{b!r}].start",
                    starts[b][0],
                    f"a start at least {ra + rb:.2f} m from {a!r}'s (their bodies would "
                    f"overlap; it is {distance:.2f} m away)",
                )
