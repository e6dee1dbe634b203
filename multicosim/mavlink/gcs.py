"""The ground station inside ``simulation.firmware.send``: upload, arm, start, record.

It is a firmware (it drives the simulated clock while a mission flies) that talks MAVLink 2
to the autopilot over the uplink/downlink topics exactly as QGroundControl or MAVSDK talk to
an autopilot over UDP: parameter protocol to set speeds and acceptance radius, mission protocol to
upload the plan, COMMAND_LONG to arm and start, telemetry to record the trajectory.

The protocols are MAVLink's and shared by every autopilot; what differs between autopilots
(flight modes, parameter names, the mission's layout, the arming and start sequence, when a
mission counts as done) is a ``Procedure``: PX4's in ``multicosim.px4.procedure``,
ArduPilot's in [`multicosim.ardupilot`][multicosim.ardupilot].
"""

from __future__ import annotations

import math
from typing import Any, Literal

import msgspec

from ..physics.obstacles import NO_OBSTACLES
from ..runtime.context import FirmwareContext
from ..runtime.serve import Firmware
from .dialect import (
    CMD_REQUEST_MESSAGE,
    FRAME_GLOBAL_REL_INT,
    LANDED_ON_GROUND,
    MAV_AUTOPILOT_INVALID,
    MAV_TYPE_GCS,
    MISSION_TYPE_MISSION,
    MODE_FLAG_ARMED,
    MSG_AUTOPILOT_VERSION,
    PREARM_BIT,
    SEV_CRITICAL,
    decode_frames,
    new_link,
)
from .hil import MavlinkPacket, Truth
from .mission import Collision, Configuration, FlightSample, MissionResult, WaypointReached
from .plan_link import last_to_reach, upload_plan_areas, waypoint_indices

__all__ = [
    "GcsSpec",
    "GroundStation",
    "MissionFailed",
    "Procedure",
    "ground_station",
]


class GcsSpec(msgspec.Struct, frozen=True, kw_only=True):
    """Where the ground station finds the autopilot's link and the world's truth.

    ``dialect`` is the MAVLink dialect it decodes (``ardupilotmega`` for ArduPilot, whose
    own messages ``common`` does not know); ``obstacles`` the world's obstacles' names, in
    order (a collision is reported by name).
    """

    uplink: str
    downlink: str
    truth: str
    period: float = 0.05
    preflight_timeout: float = 30.0
    command_timeout: float = 1.0
    system_id: int = 255
    component_id: int = 190
    dialect: Literal["common", "ardupilotmega"] = "common"
    obstacles: tuple[str, ...] = ()


class MissionFailed(Exception):
    """Raised inside the ground station to end a mission early with a reason."""


class Procedure:
    """How one autopilot is flown: what differs between autopilots, in one place.

    The ground station calls, in this order: ``prepare`` (after the first HEARTBEAT),
    waits until nothing is ``unready``, sets ``parameters``, uploads ``mission_items``, calls
    ``start`` (arm, take off, start the mission), then ``finished`` at every step until it
    says the mission is done. Subclasses say what their autopilot does; the defaults are what
    MAVLink prescribes (pre-arm checks in SYS_STATUS, home in HOME_POSITION, the landed
    state in EXTENDED_SYS_STATE).
    """

    first_waypoint = 1
    """Mission sequence number of the configuration's first waypoint."""

    plan_offset = 0
    """Mission sequence number of a plan's first item (1 where the autopilot keeps home at 0)."""

    def mode_label(self, heartbeat: Any) -> str:
        """The flight mode's name from a HEARTBEAT (``AUTO.MISSION``, ``GUIDED``, ...)."""
        raise NotImplementedError

    def prepare(self, gs: GroundStation, config: Configuration) -> None:
        """Anything to do once the autopilot is heard, before waiting for it to be ready."""

    def unready(self, gs: GroundStation) -> str:
        """What the autopilot still lacks before a mission can start ("" once it is ready).

        It must report its pre-arm checks passed (unless it already flies: an armed vehicle
        takes a new mission as it is) and its home position.
        """
        status = gs.sys_status
        if not gs.armed:
            if status is None:
                return "no SYS_STATUS from the autopilot"
            if not status.onboard_control_sensors_health & PREARM_BIT:
                return gs.why("its pre-arm checks do not pass")
        if gs.home is None:
            return "no HOME_POSITION from the autopilot"
        return ""

    def parameters(self, config: Configuration) -> list[tuple[str, float]]:
        """The parameters that carry the configuration's speed and acceptance radius."""
        raise NotImplementedError

    def mission_items(
        self, gs: GroundStation, config: Configuration, home_lat: float, home_lon: float
    ) -> list[Any]:
        """The MISSION_ITEM_INTs that fly ``config``."""
        raise NotImplementedError

    def start(self, gs: GroundStation, config: Configuration) -> None:
        """Arm and start the uploaded mission; MissionFailed if the autopilot refuses."""
        raise NotImplementedError

    def finished(self, gs: GroundStation, config: Configuration, waypoints_done: bool) -> bool:
        """Whether the mission is over and done (MissionFailed if it ended otherwise).

        A vehicle that flies ends disarmed on the ground: holding at the last waypoint is
        done once it is reached, landing or returning once it has landed and disarmed.
        """
        if config.end == "hold" and waypoints_done:
            return True
        if not gs.armed:
            # Disarmed: the end of the flight. The landed state may lag the heartbeat.
            gs.wait(lambda: gs.landed_state == LANDED_ON_GROUND, 2.0)
            if waypoints_done and gs.landed_state == LANDED_ON_GROUND:
                return True
            raise MissionFailed(gs.why("disarmed before the mission completed"))
        return False

    def landed(self, gs: GroundStation) -> bool:
        """Whether the vehicle is on the ground (EXTENDED_SYS_STATE)."""
        return gs.landed_state == LANDED_ON_GROUND


class GroundStation:
    """A MAVLink ground station stepping on the simulated clock."""

    def __init__(self, ctx: FirmwareContext, spec: GcsSpec, procedure: Procedure) -> None:
        self.ctx = ctx
        self.spec = spec
        self.procedure = procedure
        self.mav: Any = new_link(spec.system_id, spec.component_id, spec.dialect)
        self.down = ctx.subscribe(spec.downlink, MavlinkPacket)
        self.truth = ctx.subscribe(spec.truth, Truth)
        self.target = (1, 1)
        self.heartbeat: Any = None
        self.sys_status: Any = None
        self.landed_state = 0
        self.home: Any = None
        self.attitude: Any = None
        self.local: Any = None
        self.current = 0
        self.mission_state = 0
        self.mission_total = -1
        self.uploaded = 0
        self.texts: list[str] = []
        self.critical: list[str] = []
        self.acks: dict[int, int] = {}
        self.mission_ack: Any = None
        self.requested: list[int] = []
        self.params: dict[str, float] = {}
        self.reached: list[tuple[int, float]] = []
        self.samples: list[FlightSample] = []
        self.recording = False
        self.position: Any = None
        self.version = ""
        self.collision: Collision | None = None
        self._next_heartbeat = 0.0

    # -- link -------------------------------------------------------------------------------

    @property
    def armed(self) -> bool:
        """The autopilot's armed flag from its last HEARTBEAT."""
        return bool(self.heartbeat is not None and self.heartbeat.base_mode & MODE_FLAG_ARMED)

    @property
    def mode(self) -> str:
        """The autopilot's flight mode from its last HEARTBEAT."""
        hb = self.heartbeat
        return self.procedure.mode_label(hb) if hb is not None else ""

    def send(self, msg: Any) -> None:
        """Send one MAVLink message to the autopilot."""
        self.ctx.publish(self.spec.uplink, MavlinkPacket(bytes(msg.pack(self.mav))))
        self.mav.seq = (self.mav.seq + 1) & 0xFF

    def step(self) -> None:
        """Advance one period of simulated time and take in what the autopilot sent."""
        ctx = self.ctx
        if ctx.time >= self._next_heartbeat:
            self._next_heartbeat = ctx.time + 1.0
            self.send(self.mav.heartbeat_encode(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0))
        ctx.step()
        for packet in self.down.messages:
            for m in decode_frames(self.mav, packet.data):
                self._on(m)
        # One sample a step, whatever the autopilot streams at (and while it reports no
        # position, as during a GPS loss, with the last it reported).
        if self.recording and self.position is not None:
            self._sample(self.position)
        truth = self.truth.latest
        hit = truth.proximity if truth is not None else None
        if hit is not None and hit.hit >= 0 and self.collision is None and self.recording:
            names = self.spec.obstacles
            name = names[hit.hit] if hit.hit < len(names) else ""
            self.collision = Collision(
                time=hit.hit_time, obstacle=hit.hit, name=name, speed=hit.hit_speed
            )
            what = f"obstacle {hit.hit}" + (f" ({name!r})" if name else "")
            raise MissionFailed(
                f"collision with {what} at t={hit.hit_time:.2f} s ({hit.hit_speed:.1f} m/s)"
            )

    def _on(self, m: Any) -> None:
        kind = m.get_type()
        if kind == "GLOBAL_POSITION_INT":
            self.position = m
        elif kind == "ATTITUDE":
            self.attitude = m
        elif kind == "LOCAL_POSITION_NED":
            self.local = m
        elif kind == "HEARTBEAT":
            self.target = (m.get_srcSystem(), m.get_srcComponent())
            self.heartbeat = m
        elif kind == "SYS_STATUS":
            self.sys_status = m
        elif kind == "EXTENDED_SYS_STATE":
            self.landed_state = m.landed_state
        elif kind == "HOME_POSITION":
            self.home = m
        elif kind == "MISSION_CURRENT":
            self.current = m.seq
            self.mission_state = getattr(m, "mission_state", 0)
            self.mission_total = getattr(m, "total", -1)
        elif kind == "MISSION_ITEM_REACHED":
            if all(seq != m.seq for seq, _ in self.reached):
                self.reached.append((m.seq, self.ctx.time))
        elif kind == "STATUSTEXT":
            text = m.text if isinstance(m.text, str) else m.text.decode(errors="replace")
            text = text.rstrip("\0\t\r\n ")  # some autopilots end their texts with a tab
            self.texts.append(text)
            if m.severity <= SEV_CRITICAL:
                self.critical.append(text)
        elif kind == "COMMAND_ACK":
            self.acks[m.command] = m.result
        elif kind == "MISSION_ACK":
            self.mission_ack = m
        elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            self.requested.append(m.seq)
        elif kind == "AUTOPILOT_VERSION":
            v = m.flight_sw_version
            self.version = f"{v >> 24 & 0xFF}.{v >> 16 & 0xFF}.{v >> 8 & 0xFF}"
        elif kind == "PARAM_VALUE":
            name = m.param_id if isinstance(m.param_id, str) else m.param_id.decode()
            self.params[name.split("\0", 1)[0]] = m.param_value

    def _sample(self, g: Any) -> None:
        att, loc = self.attitude, self.local
        truth = self.truth.latest
        near = truth.proximity if truth else NO_OBSTACLES
        hb = self.heartbeat
        self.samples.append(
            FlightSample(
                time=self.ctx.time,
                lat=g.lat * 1e-7,
                lon=g.lon * 1e-7,
                alt=g.relative_alt * 1e-3,
                x=loc.x if loc else math.nan,
                y=loc.y if loc else math.nan,
                z=loc.z if loc else math.nan,
                vx=g.vx * 0.01,
                vy=g.vy * 0.01,
                vz=g.vz * 0.01,
                roll=att.roll if att else math.nan,
                pitch=att.pitch if att else math.nan,
                yaw=att.yaw if att else math.nan,
                mode=self.procedure.mode_label(hb) if hb else "",
                armed=self.armed,
                current=self.current,
                true_lat=truth.lat if truth else math.nan,
                true_lon=truth.lon if truth else math.nan,
                true_alt=truth.alt if truth else math.nan,
                clearance=near.clearance,
                footprint_clearance=near.footprint,
                collision=near.contact >= 0 or (near.hit >= 0 and self.collision is None),
            )
        )

    def wait(self, done: Any, timeout: float) -> bool:
        """Step until ``done()`` holds (True) or ``timeout`` simulated seconds pass (False)."""
        deadline = self.ctx.time + timeout
        while not done():
            if self.ctx.time >= deadline:
                return False
            self.step()
        return True

    def why(self, default: str) -> str:
        """The autopilot's last critical STATUSTEXT, else ``default`` (for failure reasons)."""
        return self.critical[-1] if self.critical else default

    # -- protocols --------------------------------------------------------------------------

    def command(self, command: int, *params: float, tries: int = 3) -> int:
        """COMMAND_LONG with retransmission; the COMMAND_ACK result (-1: no answer)."""
        timeout = self.spec.command_timeout
        p = [*params, *([0.0] * (7 - len(params)))]
        for attempt in range(tries):
            self.acks.pop(command, None)
            self.send(self.mav.command_long_encode(*self.target, command, attempt, *p))
            if self.wait(lambda: command in self.acks, timeout):
                return self.acks[command]
        return -1

    def set_param(self, name: str, value: float) -> bool:
        """PARAM_SET, confirmed by the PARAM_VALUE echo."""
        timeout = self.spec.command_timeout
        for _ in range(3):
            self.params.pop(name, None)
            self.send(self.mav.param_set_encode(*self.target, name.encode(), value, 9))
            if self.wait(lambda: name in self.params, timeout):
                return abs(self.params[name] - value) < 1e-4 * max(1.0, abs(value))
        return False

    def upload(
        self, items: list[Any], timeout: float = 5.0, mission_type: int = MISSION_TYPE_MISSION
    ) -> int:
        """Mission protocol upload (count, request_int*, item_int*, ack); the ack type."""
        for _ in range(3):
            self.mission_ack = None
            self.requested = []
            self.send(self.mav.mission_count_encode(*self.target, len(items), mission_type))
            deadline = self.ctx.time + timeout
            while self.ctx.time < deadline:
                if self.mission_ack is not None:
                    return int(self.mission_ack.type)
                for seq in self.requested:
                    if 0 <= seq < len(items):
                        self.send(items[seq])
                        deadline = self.ctx.time + timeout
                self.requested = []
                self.step()
        return -1

    def item(
        self,
        seq: int,
        command: int,
        *,
        frame: int = FRAME_GLOBAL_REL_INT,
        params: tuple[float, float, float, float] = (0, 0, 0, math.nan),
        lat: float = 0.0,
        lon: float = 0.0,
        alt: float = 0.0,
    ) -> Any:
        """One MISSION_ITEM_INT (auto-continue) for the autopilot."""
        return self.mav.mission_item_int_encode(
            *self.target,
            seq,
            frame,
            command,
            0,
            1,
            *params,
            round(lat * 1e7),
            round(lon * 1e7),
            alt,
            0,
        )

    # -- the mission ------------------------------------------------------------------------

    def fly(self, config: Configuration) -> MissionResult:
        """Prepare, upload, arm, start and follow ``config``; always returns a result."""
        self.step()  # joins the clock: the context's time is now the simulation's
        start = self.ctx.time
        reason = ""
        completed = False
        try:
            completed = self._fly(config, start)
        except MissionFailed as exc:
            reason = str(exc)
        index = waypoint_indices(config, self.procedure.first_waypoint, self.procedure.plan_offset)
        first: dict[int, float] = {}
        for seq, t in self.reached:
            if seq in index:
                first.setdefault(index[seq], t)
        reached = [WaypointReached(index=i, time=t) for i, t in first.items()]
        return MissionResult(
            trajectory=self.samples,
            reached=reached,
            completed=completed,
            reason=reason,
            start_time=start,
            end_time=self.ctx.time,
            landed=self.procedure.landed(self),
            armed=self.armed,
            messages=list(self.texts),
            firmware_version=self.version,
            collision=self.collision,
            min_clearance=min((s.clearance for s in self.samples), default=math.inf),
        )

    def _fly(self, config: Configuration, start: float) -> bool:
        procedure = self.procedure
        deadline = start + config.time_limit
        self.recording = True
        if not self.wait(lambda: self.heartbeat is not None, min(10.0, config.time_limit)):
            raise MissionFailed("no HEARTBEAT from the autopilot")
        # Which firmware flies (for the result); no answer is no failure.
        self.command(CMD_REQUEST_MESSAGE, MSG_AUTOPILOT_VERSION, tries=1)
        procedure.prepare(self, config)
        ready = self.wait(
            lambda: not procedure.unready(self),
            min(self.spec.preflight_timeout, deadline - self.ctx.time),
        )
        if not ready and self.ctx.time >= deadline:
            raise MissionFailed(
                f"time limit of {config.time_limit:g} s reached before arming: "
                + procedure.unready(self)
            )
        for name, value in procedure.parameters(config):
            if not self.set_param(name, value):
                raise MissionFailed(f"the autopilot did not accept parameter {name}={value:g}")
        home = self.home
        home_lat = home.latitude * 1e-7 if home else config.mission[0].lat
        home_lon = home.longitude * 1e-7 if home else config.mission[0].lon
        if config.plan is not None:
            failure = upload_plan_areas(self, config.plan)
            if failure:
                raise MissionFailed(failure)
        items = procedure.mission_items(self, config, home_lat, home_lon)
        ack = self.upload(items)
        self.uploaded = len(items)
        if ack != 0:
            raise MissionFailed(
                self.why(f"mission upload failed (MISSION_ACK {ack})")
                if ack >= 0
                else "mission upload timed out"
            )
        procedure.start(self, config)
        index = waypoint_indices(config, self.procedure.first_waypoint, self.procedure.plan_offset)
        last = last_to_reach(config)
        while True:
            if self.ctx.time >= deadline:
                raise MissionFailed(
                    f"time limit of {config.time_limit:g} s reached"
                    f" ({len({index[s] for s, _ in self.reached if s in index})}"
                    f" of {len(config.mission)} waypoints reached)"
                )
            self.step()
            # Items are flown in order: the last waypoint reached means all were. (What
            # follows it, land or return, is a mode of its own: PX4 reports no item reached
            # for a return-to-launch.)
            waypoints_done = last < 0 or any(index.get(seq) == last for seq, _ in self.reached)
            if procedure.finished(self, config, waypoints_done):
                return True


def ground_station(
    spec: GcsSpec, procedure: Procedure, name: str = "gcs"
) -> Firmware[Configuration, MissionResult]:
    """The ground-station firmware for ``spec``: send it a Configuration, get a MissionResult.

    ``procedure`` says how to fly the autopilot.
    """

    def handler(config: Configuration, ctx: FirmwareContext) -> MissionResult:
        return GroundStation(ctx, spec, procedure).fly(config)

    return Firmware(handler, Configuration, spec.period, name)
