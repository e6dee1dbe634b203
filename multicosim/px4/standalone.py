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
from .autopilot.firmware import Autopilot
from .scenario import PX4Component, WorldComponent
from .sitl import SITL

__all__ = ["StandalonePX4", "paced_params", "run_real_sitl", "run_sitl"]

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
    # PX4's API-link streams: what MAVSDK and ground stations get from real PX4 SITL.
    spec = msgspec.structs.replace(px4.spec, streams="onboard")
    sim = ProcessSimulator(seed=seed, realtime=speed)
    sim.add(WorldComponent(world, fidelity, placement="in-process", wire=spec.wire))
    sim.add(InProcessComponent(lambda: Autopilot(spec), "px4"))
    bridge_id = sim.add(
        InProcessComponent(lambda: UdpBridge(links, spec.uplink, spec.downlink, spec.period), "udp")
    )
    with sim.start() as simulation:
        bridge: Any = simulation.get(bridge_id).participant
        if on_ready is not None:
            on_ready(bridge.local_ports)
        log.info("SITL running at %gx real time; links %s", speed, links)
        return _run(simulation, duration, stop)


def _run(simulation: Any, duration: float | None, stop: threading.Event | None) -> float:
    """Advance ``simulation`` until ``duration`` or ``stop``; the simulated time reached."""
    while (stop is None or not stop.is_set()) and (duration is None or simulation.time < duration):
        step = 0.25 if duration is None else min(0.25, duration - simulation.time)
        simulation.advance(max(step, 1e-3))
    return float(simulation.time)


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
        return _run(simulation, duration, stop)
