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
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import msgspec

from ..core.errors import ConfigurationError
from ..core.fidelity import Fidelity, check_fidelity
from ..core.interfaces import Node, NodeId
from ..local import InProcessComponent, InProcessFirmwareComponent, InProcessNode
from ..mavlink.flights import fly_together
from ..mavlink.gcs import GcsSpec, GroundStation
from ..mavlink.mission import Configuration, MissionResult
from ..physics.config import WorldConfig
from ..physics.encounter import NMAC, WellClear, check_volume
from ..physics.fleet import Pose, member_names
from ..placement import ParticipantProgram, Placement, Scenario, ScenarioSimulation, resolve
from ..px4.procedure import PX4Procedure
from ..px4.scenario import LOW_PERIOD, PX4Component, default_world, sitl_period
from ..px4.sitl import SITL
from ..px4.standalone import StandalonePX4, paced_params
from ..px4.world import WorldSpec
from ..quadrotor.airframe import NONE_IRIS
from ..quadrotor.topics import SENSORS, world_topics
from ..runtime.serve import Firmware
from .monitor import EncounterMonitor
from .results import FleetMissions, FleetResult
from .world import FleetWorldSpec

if TYPE_CHECKING:
    from ..local import ProcessSimulation
    from ..runtime.context import FirmwareContext

__all__ = ["Fleet", "FleetFlights", "FleetSimulation", "PX4Vehicle"]


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
    """Real PX4 keeping its usual MAVLink ports (QGroundControl on UDP 14550, MAVSDK on
    14540 + its instance), for a ground station of one's own; ``fly`` does not fly it."""

    def __post_init__(self) -> None:
        if not isinstance(self.start, Pose):
            raise ConfigurationError("start", self.start, "a physics.Pose")
        if self.firmware is not None and not isinstance(self.firmware, SITL):
            raise ConfigurationError(
                "firmware", self.firmware, "None (the built-in autopilot) or a px4.SITL"
            )
        if self.own_links and self.firmware is None:
            raise ConfigurationError(
                "own_links", True, "False for the built-in autopilot (only real PX4 has them)"
            )


class FleetFlights(msgspec.Struct, frozen=True):
    """The ground station's answer: each vehicle's mission result, by name."""

    results: dict[str, MissionResult]


def fleet_ground_station(
    specs: Mapping[str, GcsSpec], period: float, name: str = "fleet.gcs"
) -> Firmware[FleetMissions, FleetFlights]:
    """The ground station that flies a mission per vehicle at once (``specs``: each one's)."""
    specs = dict(specs)

    def handler(msg: FleetMissions, ctx: FirmwareContext) -> FleetFlights:
        unknown = sorted(set(msg.missions) - set(specs))
        if unknown:
            raise ConfigurationError("missions", unknown[0], f"one of {sorted(specs)}")
        runs = {
            vehicle: _flight(specs[vehicle], config) for vehicle, config in msg.missions.items()
        }
        return FleetFlights(results=fly_together(ctx, runs))

    return Firmware(handler, FleetMissions, period, name)


def _flight(spec: GcsSpec, config: Configuration) -> Any:
    def fly(ctx: Any) -> MissionResult:
        return GroundStation(ctx, spec, PX4Procedure()).fly(config)

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
    ) -> None:
        super().__init__(simulation)
        self.vehicles: dict[str, Any] = {n: simulation.get(i) for n, i in vehicles.items()}
        self._flown = sorted(set(vehicles) - own_links)
        self._gcs = simulation.get(gcs)
        self._monitor: EncounterMonitor = simulation.get(monitor).participant

    def fly(self, missions: Mapping[str, Configuration]) -> FleetResult:
        """Fly ``missions`` (a Configuration per vehicle, by name) at once, on one clock;
        each vehicle's result and the encounter so far."""
        for vehicle, config in missions.items():
            if vehicle not in self._flown:
                raise ConfigurationError(
                    "missions",
                    vehicle,
                    f"one of {self._flown} (a vehicle with its own links is not)",
                )
            self.vehicles[vehicle].check(config)
        flights = self._gcs.send(FleetMissions(missions=dict(missions)))
        return FleetResult(results=flights.results, encounter=self._monitor.encounter())

    def encounter(self) -> Any:
        """The encounter measured so far (:class:`~multicosim.fleet.Encounter`)."""
        return self._monitor.encounter()


class Fleet(Scenario[FleetSimulation]):
    """Several PX4 quadrotors in one world at ``fidelity``, each flown by its autopilot.

    ``vehicles`` names each vehicle (letters, digits, ``_``, ``-``) and says what it is and
    where it starts; their topics (and trace channels) are under their names. ``world`` is
    the world's configuration (None: the fidelity's), ``well_clear`` the volume the
    encounter judges (a :class:`~multicosim.physics.WellClear` or a preset's name:
    ``"NMAC"``, ``"DO-365"``, ``"ASTM F3442"``). ``placement``, ``seed``, ``realtime``
    and ``run_dir`` are every scenario's.
    """

    def __init__(
        self,
        vehicles: Mapping[str, PX4Vehicle],
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
            if not isinstance(vehicles[name], PX4Vehicle):
                raise ConfigurationError(f"vehicles[{name!r}]", vehicles[name], "a PX4Vehicle")
        self.volume = check_volume(well_clear)
        real = any(v.firmware is not None for v in vehicles.values())
        if real and fidelity == "low":
            raise ConfigurationError(
                "fidelity", fidelity, "'medium' or 'high' with real PX4 (it flies MuJoCo)"
            )
        _check_starts({n: v.start for n, v in vehicles.items()}, world)
        super().__init__(
            fidelity=fidelity, placement=placement, seed=seed, realtime=realtime, run_dir=run_dir
        )
        base = world if world is not None else default_world(self.fidelity)
        if real:
            base = dataclasses.replace(base, period=sitl_period(base))
        self.world = base
        self.vehicles = dict(vehicles)
        # With real PX4 the world is its simulator, in this process beside its bridges.
        world_placement = resolve("in-process", self.fidelity) if real else self.placement
        self.components = {
            name: PX4Component(
                self._world_of(name),
                self.fidelity,
                name=name,
                # Wall-clock clients of a paced PX4 get its paced loss timeouts; a user's win.
                params={
                    **(paced_params(realtime or 1.0) if vehicle.own_links else {}),
                    **vehicle.params,
                },
                placement=vehicle.placement if vehicle.placement is not None else self.placement,
                firmware=vehicle.firmware,
            )
            for name, vehicle in self.vehicles.items()
        }
        own = {n for n, v in self.vehicles.items() if v.own_links}
        self.world_ids: list[NodeId[Node]] = []
        if self.fidelity == "low":
            for name, vehicle in self.vehicles.items():
                spec = WorldSpec(
                    model="point_mass",
                    world=self._world_of(name),
                    wire=self.components[name].spec.wire,
                    point_mass_period=LOW_PERIOD,
                    start=vehicle.start,
                )
                program = ParticipantProgram("multicosim.px4.world:world", spec, f"{name}.world")
                self.world_ids.append(self._add_own(world_placement.participant(program)))
        else:
            spec_m = FleetWorldSpec(
                world=base,
                vehicles={n: v.start for n, v in self.vehicles.items()},
                wires={n: c.spec.wire for n, c in self.components.items()},
            )
            program = ParticipantProgram("multicosim.fleet.world:world", spec_m, "world")
            self.world_ids.append(self._add_own(world_placement.participant(program)))
        period = LOW_PERIOD if self.fidelity == "low" else base.period
        monitor_period = max(period, 0.05)
        truths = {name: world_topics(self._world_of(name)).truth for name in names}
        volume = self.volume
        analytic = self.fidelity == "low"
        self.monitor_id: NodeId[InProcessNode[EncounterMonitor]] = self._add_own(
            InProcessComponent(
                lambda: EncounterMonitor(
                    truths,
                    dict.fromkeys(names, NONE_IRIS.radius),
                    volume,
                    monitor_period,
                    analytic=analytic,
                ),
                "encounter",
            )
        )
        first = None
        self.vehicle_ids: dict[str, NodeId[Any]] = {}
        for name, component in self.components.items():
            added: Any = component
            if name in own:
                assert component.firmware is not None
                added = StandalonePX4(
                    component.firmware,
                    component.world,
                    component.sitl_params(),
                    resolve(component.placement, self.fidelity),
                    name,
                )
            node_id = self._add_own(added, anchor=first is None)
            first = first or node_id
            self.vehicle_ids[name] = node_id
        specs = {n: c.gcs_spec() for n, c in self.components.items() if n not in own}
        gcs_period = min((s.period for s in specs.values()), default=0.05)
        self.gcs_id = self._add_own(
            InProcessFirmwareComponent(fleet_ground_station(specs, gcs_period), name="fleet.gcs")
        )

    def _world_of(self, name: str) -> WorldConfig:
        """The world as vehicle ``name`` sees it: its topics under its name."""
        return dataclasses.replace(self.world, sensor_topics={s: f"{name}/{s}" for s in SENSORS})

    def start(self) -> FleetSimulation:
        """Start every vehicle's world and autopilot, the monitor and the ground station."""
        return FleetSimulation(
            self._start_simulation(),
            self.vehicle_ids,
            self.gcs_id,
            self.monitor_id,
            frozenset(n for n, v in self.vehicles.items() if v.own_links),
        )


def _check_starts(starts: Mapping[str, Pose], world: WorldConfig | None) -> None:
    """Two vehicles that would start overlapping (their bodies' spheres) are refused."""
    home = (world or WorldConfig()).home
    from ..physics.fleet import resolve_pose

    placed = {n: resolve_pose(p, home)[:3] for n, p in starts.items()}
    names = list(placed)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            (na, ea, ua), (nb, eb, ub) = placed[a], placed[b]
            distance = ((na - nb) ** 2 + (ea - eb) ** 2 + (ua - ub) ** 2) ** 0.5
            if distance < 2 * NONE_IRIS.radius:
                raise ConfigurationError(
                    f"vehicles[{b!r}].start",
                    starts[b],
                    f"a start at least {2 * NONE_IRIS.radius:.2f} m from {a!r}'s (their "
                    f"bodies would overlap; it is {distance:.2f} m away)",
                )
