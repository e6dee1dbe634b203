"""The ground station inside ``simulation.firmware.send``: upload, arm, start, record.

It is a firmware (it drives the simulated clock while a mission flies) that talks MAVLink 2
to the autopilot over the uplink/downlink topics exactly as QGroundControl or MAVSDK talk to
PX4 over UDP: parameter protocol to set speeds and acceptance radius, mission protocol to
upload the plan, COMMAND_LONG to arm and start, telemetry to record the trajectory.
"""

from __future__ import annotations

import math
from typing import Any

import msgspec

from .._runtime import Firmware, FirmwareContext
from ._config import Configuration, MissionResult, Sample, WaypointReached
from ._hil import MavlinkPacket, Truth
from ._mav import decode_frames, mode_label, new_link

__all__ = ["GcsSpec", "GroundStation", "ground_station"]

MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID = 6, 8
FRAME_MISSION, FRAME_GLOBAL_REL_INT = 2, 6
CMD_WAYPOINT, CMD_RTL, CMD_LAND, CMD_TAKEOFF = 16, 20, 21, 22
CMD_MISSION_START, CMD_ARM_DISARM, CMD_REQUEST_MESSAGE = 300, 400, 512
MSG_AUTOPILOT_VERSION = 148
PREARM_BIT = 0x10000000
LANDED_ON_GROUND = 1
SEV_CRITICAL = 2


class GcsSpec(msgspec.Struct, frozen=True, kw_only=True):
    """Where the ground station finds the autopilot's link and the world's truth."""

    uplink: str = "px4/mavlink/up"
    downlink: str = "px4/mavlink/down"
    truth: str = "px4/truth"
    period: float = 0.05
    preflight_timeout: float = 30.0
    command_timeout: float = 1.0
    system_id: int = 255
    component_id: int = 190


class MissionFailed(Exception):
    """Raised inside the ground station to end a mission early with a reason."""


class GroundStation:
    """A MAVLink ground station stepping on the simulated clock."""

    def __init__(self, ctx: FirmwareContext, spec: GcsSpec) -> None:
        self.ctx = ctx
        self.spec = spec
        self.mav: Any = new_link(spec.system_id, spec.component_id)
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
        self.texts: list[str] = []
        self.critical: list[str] = []
        self.acks: dict[int, int] = {}
        self.mission_ack: Any = None
        self.requested: list[int] = []
        self.params: dict[str, float] = {}
        self.reached: list[tuple[int, float]] = []
        self.samples: list[Sample] = []
        self.recording = False
        self.position: Any = None
        self.version = ""
        self._next_heartbeat = 0.0

    # -- link -------------------------------------------------------------------------------

    @property
    def armed(self) -> bool:
        """The autopilot's armed flag from its last HEARTBEAT."""
        return bool(self.heartbeat is not None and self.heartbeat.base_mode & 128)

    @property
    def mode(self) -> str:
        """The autopilot's flight mode (PX4 name) from its last HEARTBEAT."""
        return mode_label(self.heartbeat.custom_mode) if self.heartbeat is not None else ""

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
        elif kind == "MISSION_ITEM_REACHED":
            if all(seq != m.seq for seq, _ in self.reached):
                self.reached.append((m.seq, self.ctx.time))
        elif kind == "STATUSTEXT":
            text = m.text if isinstance(m.text, str) else m.text.decode(errors="replace")
            text = text.rstrip("\0\t\r\n ")  # PX4 ends its event texts with a tab
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
        hb = self.heartbeat
        self.samples.append(
            Sample(
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
                mode=mode_label(hb.custom_mode) if hb else "",
                armed=bool(hb and hb.base_mode & 128),
                current=self.current,
                true_lat=truth.lat if truth else math.nan,
                true_lon=truth.lon if truth else math.nan,
                true_alt=truth.alt if truth else math.nan,
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

    def upload(self, items: list[Any], timeout: float = 5.0) -> int:
        """Mission protocol upload (count, request_int*, item_int*, ack); the ack type."""
        for _ in range(3):
            self.mission_ack = None
            self.requested = []
            self.send(self.mav.mission_count_encode(*self.target, len(items), 0))
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

    def mission_items(self, config: Configuration, home_lat: float, home_lon: float) -> list[Any]:
        """The MISSION_ITEM_INTs for ``config``: takeoff, waypoints, then land or RTL."""
        enc = self.mav.mission_item_int_encode
        t_sys, t_comp = self.target
        wps = config.mission
        takeoff = config.takeoff_alt if config.takeoff_alt is not None else wps[0].alt
        acc = config.acceptance_radius
        items = [
            enc(
                t_sys,
                t_comp,
                0,
                FRAME_GLOBAL_REL_INT,
                CMD_TAKEOFF,
                0,
                1,
                0,
                0,
                0,
                math.nan,
                # Where it stands: PX4 checks the first item's distance from home.
                round(home_lat * 1e7),
                round(home_lon * 1e7),
                takeoff,
                0,
            )
        ]
        for wp in wps:
            items.append(
                enc(
                    t_sys,
                    t_comp,
                    len(items),
                    FRAME_GLOBAL_REL_INT,
                    CMD_WAYPOINT,
                    0,
                    1,
                    0,
                    acc,
                    0,
                    math.nan,
                    round(wp.lat * 1e7),
                    round(wp.lon * 1e7),
                    wp.alt,
                    0,
                )
            )
        last = wps[-1]
        if config.end == "land":
            items.append(
                enc(
                    t_sys,
                    t_comp,
                    len(items),
                    FRAME_GLOBAL_REL_INT,
                    CMD_LAND,
                    0,
                    1,
                    0,
                    0,
                    0,
                    math.nan,
                    round(last.lat * 1e7),
                    round(last.lon * 1e7),
                    0,
                    0,
                )
            )
        elif config.end == "rtl":
            items.append(
                enc(
                    t_sys,
                    t_comp,
                    len(items),
                    FRAME_MISSION,  # no position: PX4 refuses RTL in a global frame
                    CMD_RTL,
                    0,
                    1,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                )
            )
        return items

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
        n = len(config.mission)
        reached = [
            WaypointReached(index=seq - 1, time=t) for seq, t in self.reached if 1 <= seq <= n
        ]
        return MissionResult(
            trajectory=self.samples,
            reached=reached,
            completed=completed,
            reason=reason,
            start_time=start,
            end_time=self.ctx.time,
            landed=self.landed_state == LANDED_ON_GROUND,
            armed=self.armed,
            messages=list(self.texts),
            firmware_version=self.version,
        )

    def _why(self, default: str) -> str:
        return self.critical[-1] if self.critical else default

    def _fly(self, config: Configuration, start: float) -> bool:
        deadline = start + config.time_limit
        self.recording = True
        if not self.wait(lambda: self.heartbeat is not None, min(10.0, config.time_limit)):
            raise MissionFailed("no HEARTBEAT from the autopilot")
        # Which firmware flies (for the result); no answer is no failure.
        self.command(CMD_REQUEST_MESSAGE, MSG_AUTOPILOT_VERSION, tries=1)
        ready = self.wait(
            lambda: (
                self.sys_status is not None
                and bool(self.sys_status.onboard_control_sensors_health & PREARM_BIT)
                and self.home is not None
            ),
            min(self.spec.preflight_timeout, deadline - self.ctx.time),
        )
        if not ready and self.ctx.time >= deadline:
            raise MissionFailed(f"time limit of {config.time_limit:g} s reached before arming")
        for name, value in (
            ("MPC_XY_CRUISE", config.cruise_speed),
            ("NAV_ACC_RAD", config.acceptance_radius),
        ):
            if not self.set_param(name, value):
                raise MissionFailed(f"the autopilot did not accept parameter {name}={value:g}")
        home = self.home
        home_lat = home.latitude * 1e-7 if home else config.mission[0].lat
        home_lon = home.longitude * 1e-7 if home else config.mission[0].lon
        items = self.mission_items(config, home_lat, home_lon)
        ack = self.upload(items)
        if ack != 0:
            raise MissionFailed(
                self._why(f"mission upload failed (MISSION_ACK {ack})")
                if ack >= 0
                else "mission upload timed out"
            )
        result = self.command(CMD_ARM_DISARM, 1.0)
        if result != 0:
            raise MissionFailed("arming refused: " + self._why(f"COMMAND_ACK result {result}"))
        # The armed state is the HEARTBEAT's: one sent before the ACK may still be the last
        # one seen, so wait for a heartbeat that says armed.
        if not self.wait(lambda: self.armed, 3.0):
            raise MissionFailed(self._why("arming was acknowledged but the vehicle is not armed"))
        result = self.command(CMD_MISSION_START, 0.0, 0.0)
        if result != 0:
            raise MissionFailed("mission start refused: " + self._why(f"result {result}"))
        last_wp_seq = len(config.mission)
        while True:
            if self.ctx.time >= deadline:
                raise MissionFailed(
                    f"time limit of {config.time_limit:g} s reached"
                    f" ({len([s for s, _ in self.reached if 1 <= s <= last_wp_seq])} of "
                    f"{len(config.mission)} waypoints reached)"
                )
            self.step()
            # Items are flown in order: the last waypoint reached means all were. (What
            # follows it, land or return, is a mode of its own: PX4 reports no item reached
            # for a return-to-launch.)
            waypoints_done = any(seq == last_wp_seq for seq, _ in self.reached)
            if config.end == "hold" and waypoints_done:
                return True
            if not self.armed:
                # Disarmed: the end of the flight. The landed state may lag the heartbeat.
                self.wait(lambda: self.landed_state == LANDED_ON_GROUND, 2.0)
                if waypoints_done and self.landed_state == LANDED_ON_GROUND:
                    return True
                raise MissionFailed(self._why("disarmed before the mission completed"))


def ground_station(
    spec: GcsSpec | None = None, name: str = "gcs"
) -> Firmware[Configuration, MissionResult]:
    """The ground-station firmware for ``spec``: send it a Configuration, get a MissionResult."""
    spec = spec or GcsSpec()

    def handler(config: Configuration, ctx: FirmwareContext) -> MissionResult:
        return GroundStation(ctx, spec).fly(config)

    return Firmware(handler, Configuration, spec.period, name)
