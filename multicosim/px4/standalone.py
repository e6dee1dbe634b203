"""Standalone SITL: world and autopilot in real time, talking MAVLink over UDP.

Like PX4 SITL, each link is a UDP socket bound on the host that sends to a fixed remote
port (14550 for a ground station such as QGroundControl, 14540 for an API client such as
MAVSDK) and, once a peer has sent something, answers that peer wherever it is. The
simulation runs paced to wall time (times ``speed``, like PX4_SIM_SPEED_FACTOR) until it is
stopped; every socket and component is released on exit, Ctrl-C included.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec

from ..core.fidelity import Fidelity
from ..local import InProcessComponent, LocalEnvironment, ProcessSimulator
from ..mavlink.udp import API_PORT, GCS_PORT, Link, UdpBridge
from ..physics.config import WorldConfig
from ..placement import Placement, as_placement
from ..placement.firmware import FirmwareNodes
from ..quadrotor.topics import world_topics
from .scenario import PX4Component, WorldComponent
from .sitl import SITL

__all__ = [
    "StandaloneAutopilot",
    "StandaloneNodes",
    "StandalonePX4",
    "paced_params",
    "run_real_sitl",
    "run_sitl",
    "run_until",
]

log = logging.getLogger(__name__)

_INT32 = 6  # MAV_PARAM_TYPE_INT32: types up to it are integers


def paced_params(speed: float) -> dict[str, float]:
    """The loss timeouts PX4 gives a simulation paced at ``speed`` x real time.

    Clients on the wall clock (MAVSDK, QGroundControl, a joystick) send as often per wall
    second at any speed, so PX4's SITL start-up (etc/init.d-posix/rcS, when
    PX4_SIM_SPEED_FACTOR is set) lengthens, in simulated seconds, the timeouts that judge
    them: at 10x, a client that pauses 60 ms is not taken for lost. Both autopilots get
    them, within each parameter's range and type (a longer timeout than its maximum already
    outlasts any pause); parameters a user sets win.
    """
    from .autopilot.params import table

    if speed == 1.0:
        return {}
    params = table()
    out = {}
    for name, per_unit in (
        ("COM_DL_LOSS_T", 10.0),
        ("COM_RC_LOSS_T", 0.5),
        ("COM_OF_LOSS_T", 0.5),
        ("COM_OBC_LOSS_T", 5.0),
    ):
        p = params[name]
        value = per_unit * speed
        value = value if p.max is None else min(value, p.max)
        value = value if p.min is None else max(value, p.min)
        out[name] = float(round(value)) if p.type <= _INT32 else value
    return out


def run_sitl(
    *,
    fidelity: Fidelity = "low",
    speed: float = 1.0,
    links: list[Link] | None = None,
    world: WorldConfig | None = None,
    seed: int = 0,
    duration: float | None = None,
    stop: threading.Event | None = None,
    on_ready: Callable[[list[int]], None] | None = None,
    params: dict[str, float] | None = None,
) -> float:
    """Run world + autopilot + UDP links paced at ``speed`` x real time.

    ``params`` are PX4 parameters the autopilot starts with.
    Runs until ``duration`` simulated seconds have passed, ``stop`` is set, or Ctrl-C; returns
    the simulated time reached. ``on_ready`` gets the bound local ports once the links exist.
    """
    world = world or WorldConfig()
    links = links if links is not None else [Link(GCS_PORT, 18570), Link(API_PORT, 14580)]
    params = {**paced_params(speed), **(params or {})}
    px4 = PX4Component(world, fidelity, params=params, placement="in-process")
    sim = ProcessSimulator(seed=seed, realtime=speed)
    sim.add(WorldComponent(world, fidelity, placement="in-process", wire=px4.spec.wire))
    px4_id: Any = sim.add(StandaloneAutopilot(px4, tuple(links)))
    with sim.start() as simulation:
        if on_ready is not None:
            on_ready(simulation.get(px4_id).ports)
        log.info("SITL running at %gx real time; links %s", speed, links)
        return run_until(simulation, duration, stop)


def run_until(simulation: Any, duration: float | None, stop: threading.Event | None) -> float:
    """Advance ``simulation`` (paced, if it is) until ``duration`` simulated seconds or
    ``stop``; the simulated time reached."""
    while (stop is None or not stop.is_set()) and (duration is None or simulation.time < duration):
        step = 0.25 if duration is None else min(0.25, duration - simulation.time)
        simulation.advance(max(step, 1e-3))
    return float(simulation.time)


class StandaloneNodes(FirmwareNodes):
    """The built-in autopilot and its UDP links, stopped as one; ``ports`` the links' own."""

    ports: list[int]


@dataclasses.dataclass(frozen=True)
class StandaloneAutopilot:
    """The built-in autopilot with MAVLink UDP links only, for a ground station of one's own.

    ``links`` None: PX4 instance N's own links, N the first free instance (claimed as real
    PX4's is): ground stations on UDP 14550 and MAVSDK on 14540 + N, MAV_SYS_ID N + 1 unless
    ``component``'s params set it, as PX4's start-up script sets them for ``px4 -i N``.
    It sends what real PX4 sends on its API link.
    """

    component: PX4Component
    links: tuple[Link, ...] | None = None
    host: str = "127.0.0.1"

    @property
    def name(self) -> str:
        """The autopilot's name (its topics' prefix)."""
        return self.component.name

    def required_images(self) -> tuple[str, ...]:
        """The images its autopilot's placement needs."""
        return self.component.required_images()

    def start(self, environment: LocalEnvironment) -> StandaloneNodes:
        """Start the autopilot where it is placed and its links here."""
        from .sitl import claim_instance, gateway_links

        group = StandaloneNodes(self.name)
        spec = msgspec.structs.replace(self.component.spec, streams="onboard")
        links = list(self.links or ())
        claim = None
        with group.starting():
            try:
                if self.links is None:
                    group.instance, claim = claim_instance(self.host, gcs_link=True)
                    links = [
                        Link(link.port, link.local_port, self.host)
                        for link in gateway_links(self.host, group.instance)
                    ]
                    params = {"MAV_SYS_ID": group.instance + 1.0, **spec.params}
                    spec = msgspec.structs.replace(spec, params=params)
                group.add("autopilot", self.component.autopilot(spec).start(environment))
                bridge = InProcessComponent(
                    lambda: UdpBridge(links, spec.uplink, spec.downlink, spec.period),
                    f"{self.name}.udp",
                ).start(environment)
            finally:
                if claim is not None:  # the bridge holds the instance's ports now
                    claim.close()
            group.add("udp", bridge)
            group.ports = bridge.participant.local_ports
        return group


@dataclasses.dataclass(frozen=True)
class StandalonePX4:
    """Real PX4 with only its simulator bridge: PX4 keeps its own MAVLink links and ports
    (QGroundControl on UDP 14550, MAVSDK on 14540 + its instance), so a ground station of
    one's own flies it. ``world`` says its topics and its world period; ``params`` are PX4's
    at boot (see ``PX4Component.sitl_params``)."""

    sitl: SITL
    world: WorldConfig
    params: dict[str, float]
    placement: Placement
    name: str = "px4"

    def start(self, environment: LocalEnvironment) -> FirmwareNodes:
        """Start PX4 and its simulator bridge; return once PX4 has connected."""
        from .sitl import start_sitl

        return start_sitl(
            self.sitl,
            self.placement,
            environment,
            name=self.name,
            topics=world_topics(self.world),
            home_alt=self.world.home.alt,
            period=self.world.period,
            wire="native",
            uplink=None,
            downlink="",
            params=self.params,
        )


def run_real_sitl(
    sitl: SITL,
    *,
    placement: str | Placement | None = None,
    speed: float = 1.0,
    world: WorldConfig | None = None,
    seed: int = 0,
    duration: float | None = None,
    stop: threading.Event | None = None,
    on_ready: Callable[[int, Path], None] | None = None,
    params: dict[str, float] | None = None,
) -> float:
    """Run real PX4 SITL on our MuJoCo world, paced at ``speed`` x real time, in lockstep.

    PX4 keeps its usual MAVLink links (QGroundControl on UDP 14550, MAVSDK on 14540 + its
    instance number), so ground stations fly it as they fly PX4 with Gazebo. ``placement``
    is where PX4 runs (default: a local process with a binary, else a container of its
    image, instance 0, whose links reach those ports on this host).
    Runs until ``duration`` simulated seconds, ``stop`` or Ctrl-C; returns the simulated
    time reached.
    ``on_ready`` gets PX4's instance number and the run directory (PX4's output and working
    directory) once PX4 is connected. ``params`` are PX4 parameters it boots with.
    """
    from .scenario import PX4Component, sitl_period

    world = world or WorldConfig()
    world = dataclasses.replace(world, period=sitl_period(world))
    params = {**paced_params(speed), **(params or {})}
    where = as_placement(placement or ("process" if sitl.binary is not None else "docker"))
    component = PX4Component(world, "medium", params=params, firmware=sitl, placement=where)
    params = component.sitl_params()
    sim = where.simulator(seed=seed, realtime=speed)
    sim.add(WorldComponent(world, "medium", placement="in-process", wire="native"))
    px4_id: Any = sim.add(StandalonePX4(sitl, world, params, where))
    with sim.start() as simulation:
        instance = simulation.get(px4_id).instance
        if on_ready is not None:
            on_ready(instance, simulation.run_dir)
        log.info("real PX4 SITL (instance %d) running at %gx real time", instance, speed)
        return run_until(simulation, duration, stop)
