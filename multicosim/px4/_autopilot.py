"""Our PX4-compatible autopilot: a participant stepped in lockstep with the world.

Inside: the estimator (:mod:`._estimator`), a commander (arming checks, flight modes,
GPS-loss failsafe, land detector, auto-disarm), a navigator (takeoff, mission items with
acceptance radii, land, return to launch, hold) and the controller (:mod:`._control`).
Outside, it looks like PX4 to both of its peers:

* simulator side: HIL_SENSOR / HIL_GPS in, HIL_ACTUATOR_CONTROLS out (topics ``topics.*``);
* ground-station side: MAVLink 2 as PX4 presents it, as packed frames on the ``uplink`` /
  ``downlink`` topics (HEARTBEAT with PX4 custom modes, telemetry, mission, command and
  parameter protocols, AUTOPILOT_VERSION). :mod:`._sitl` carries those topics over UDP.
"""

from __future__ import annotations

import logging
import math
from typing import Any, Literal

import msgspec

from .._errors import ConfigurationError
from .._runtime import StepContext, Subscription
from ..geo import LocalProjection
from ._config import Topics
from ._control import MultirotorController, position_control
from ._estimator import Estimator
from ._hil import (
    ACTUATOR_FLAG_VELOCITY,
    ARMED_FLAG,
    BARO_FIELDS,
    IMU_FIELDS,
    MAG_FIELDS,
    HilActuatorControls,
    HilGps,
    HilSensor,
    MavlinkPacket,
    Wire,
    pack,
    unpack,
)
from ._mav import MainMode, Mode, SubMode, decode_frames, dialect, new_link, pack_scalar
from ._params import Params

__all__ = ["Autopilot", "AutopilotSpec", "autopilot"]

log = logging.getLogger(__name__)

Airframe = Literal["quadrotor", "point_mass"]

# MAVLink constants used here (from the common dialect; spelled out to keep lookups cheap).
MAV_TYPE_QUADROTOR = 2
MAV_AUTOPILOT_PX4 = 12
MAV_STATE_STANDBY, MAV_STATE_ACTIVE, MAV_STATE_CRITICAL = 3, 4, 5
MODE_FLAG_CUSTOM, MODE_FLAG_AUTO, MODE_FLAG_GUIDED = 1, 4, 8
MODE_FLAG_STABILIZE, MODE_FLAG_MANUAL, MODE_FLAG_ARMED = 16, 64, 128
LANDED_ON_GROUND, LANDED_IN_AIR, LANDED_TAKEOFF, LANDED_LANDING = 1, 2, 3, 4
RESULT_ACCEPTED, RESULT_TEMP_REJECTED, RESULT_DENIED = 0, 1, 2
RESULT_UNSUPPORTED, RESULT_FAILED = 3, 4
MISSION_ACCEPTED, MISSION_ERROR, MISSION_UNSUPPORTED_FRAME = 0, 1, 2
MISSION_UNSUPPORTED, MISSION_INVALID, MISSION_INVALID_SEQUENCE = 3, 5, 13
MISSION_OPERATION_CANCELLED = 15
MISSION_TYPE_MISSION = 0
MISSION_STATE_NO_MISSION, MISSION_STATE_NOT_STARTED = 1, 2
MISSION_STATE_ACTIVE, MISSION_STATE_PAUSED, MISSION_STATE_COMPLETE = 3, 4, 5
FRAME_GLOBAL, FRAME_GLOBAL_REL, FRAME_GLOBAL_INT, FRAME_GLOBAL_REL_INT = 0, 3, 5, 6
FRAME_MISSION = 2
FRAME_LOCAL_NED = 1
# POSITION_TARGET_TYPEMASK bits: what a POSITION_TARGET_LOCAL_NED leaves unset.
TARGET_IGNORE_POSITION, TARGET_IGNORE_VELOCITY = 1 | 2 | 4, 8 | 16 | 32
TARGET_IGNORE_ACCEL, TARGET_IGNORE_YAW_RATE = 64 | 128 | 256, 2048
CMD_WAYPOINT, CMD_LOITER_UNLIM, CMD_RTL, CMD_LAND, CMD_TAKEOFF = 16, 17, 20, 21, 22
CMD_DO_CHANGE_SPEED, CMD_DO_SET_MODE, CMD_MISSION_START = 178, 176, 300
CMD_ARM_DISARM, CMD_GET_HOME, CMD_SET_MSG_INTERVAL = 400, 410, 511
CMD_REQUEST_MESSAGE, CMD_REQUEST_CAPABILITIES = 512, 520
FORCE_MAGIC = 21196
SEV_CRITICAL, SEV_WARNING, SEV_NOTICE, SEV_INFO = 2, 4, 5, 6
PARAM_REAL32 = 9

SENSOR_BITS = 1 | 2 | 4 | 8 | 32  # gyro, accel, mag, baro, GPS
CONTROL_BITS = 1024 | 2048 | 4096 | 8192 | 16384 | 32768  # rate..xy control, motor outputs
AHRS_BIT, PREARM_BIT = 0x200000, 0x10000000
CAPABILITIES = 1 | 2 | 4 | 8 | 256 | 8192  # mission float/int, param float, cmd int, ftp-less

FLIGHT_SW_VERSION = (1 << 24) | (15 << 16) | (4 << 8) | 255  # "v1.15.4 official", as PX4's
NAV_COMMANDS = {CMD_WAYPOINT, CMD_LOITER_UNLIM, CMD_RTL, CMD_LAND, CMD_TAKEOFF}
STREAM_DEFAULTS = {  # message: period (s); None for "at the telemetry rate"
    "HEARTBEAT": 1.0,
    "SYS_STATUS": 1.0,
    "EXTENDED_SYS_STATE": 1.0,
    "HOME_POSITION": 2.0,
    "MISSION_CURRENT": 1.0,
    "GPS_RAW_INT": 0.2,
    # What the position controller is asked for, to set beside what the vehicle does; PX4's
    # rate on a normal link (a ground station raises it with SET_MESSAGE_INTERVAL).
    "POSITION_TARGET_LOCAL_NED": 1.0,
    # GLOBAL_POSITION_INT last: a ground station that samples on it has the others fresh.
    "LOCAL_POSITION_NED": None,
    "ATTITUDE": None,
    "GLOBAL_POSITION_INT": None,
}


class AutopilotSpec(msgspec.Struct, frozen=True, kw_only=True):
    """Configuration of the autopilot participant (JSON-encodable, for a process)."""

    airframe: Airframe = "quadrotor"
    period: float = 0.004
    topics: Topics = msgspec.field(default_factory=Topics)
    uplink: str = "px4/mavlink/up"
    downlink: str = "px4/mavlink/down"
    wire: Wire = "native"
    telemetry_rate: float = 20.0
    params: dict[str, float] = msgspec.field(default_factory=dict)
    system_id: int = 1
    mag_declination: float = 0.0  # rad, the world's (PX4 looks it up in its field model)

    def __post_init__(self) -> None:
        if self.airframe not in ("quadrotor", "point_mass"):
            raise ConfigurationError("airframe", self.airframe, "'quadrotor' or 'point_mass'")
        if not 0.0005 <= self.period <= 0.2:
            raise ConfigurationError("period", self.period, "a period in [0.0005, 0.2] s")
        if not 1.0 <= self.telemetry_rate <= 100.0:
            raise ConfigurationError("telemetry_rate", self.telemetry_rate, "1..100 Hz")
        if not 1 <= self.system_id <= 254:
            raise ConfigurationError("system_id", self.system_id, "an integer in [1, 254]")
        Params(self.params)  # validates names and ranges


class Item(msgspec.Struct, array_like=True, gc=False):
    """A stored mission item (MISSION_ITEM_INT fields)."""

    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float


class Autopilot:
    """The autopilot participant (see the module docstring)."""

    def __init__(self, spec: AutopilotSpec | None = None) -> None:
        self.spec = spec = spec or AutopilotSpec()
        self.period = spec.period
        self.params = Params(spec.params)
        self.est = Estimator(spec.mag_declination)
        self.ctl = MultirotorController()
        self.velocity_vehicle = spec.airframe == "point_mass"
        self._d: Any = dialect()
        self.mav: Any = new_link(spec.system_id, 1)
        self._out: list[bytes] = []
        self._subs: list[tuple[Subscription[Any], bool]] = []
        self._uplink: Subscription[MavlinkPacket] | None = None
        self._now = 0.0
        self._last_imu_us: int | None = None
        # Commander state.
        self.armed = False
        self.mode = Mode.LOITER
        self.landed = True
        self.failsafe: str | None = None
        self._armed_at = 0.0
        self._flew = False
        self._landed_at: float | None = None
        self._ground_d = 0.0
        self._touch_since: float | None = None
        self.home: tuple[float, float, float, float, float, float] | None = None
        # Navigator state.
        self.mission: list[Item] = []
        self.seq = 0
        self.mission_state = MISSION_STATE_NO_MISSION
        self._phase = ""
        self._hold = (0.0, 0.0, 0.0)
        self._target: tuple[float, float, float] | None = None
        self._cruise: float | None = None
        self._yaw_sp = 0.0
        self._vz_sp = 0.0
        # The last position and velocity setpoints (local NED), for POSITION_TARGET_LOCAL_NED.
        self._pos_sp: tuple[float, float, float] | None = None
        self._vel_sp: tuple[float, float, float] | None = None
        self._reached_at: float | None = None
        # Ground-station link state.
        self._gcs = (255, 190)
        self._upload: dict[str, Any] | None = None
        self._after_ack: list[Any] = []
        self._streams: dict[str, list[float]] = {}
        rate = 1.0 / spec.telemetry_rate
        for name, per in STREAM_DEFAULTS.items():
            self._streams[name] = [rate if per is None else per, 0.0]
        self._dirty: set[str] = set()
        self._next_due = 0.0
        self._stream_list = [
            (name, slot, getattr(self, "_msg_" + name.lower()))
            for name, slot in self._streams.items()
        ]

    # -- participant ------------------------------------------------------------------------

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the sensor topics and the ground-station uplink."""
        t = self.spec.topics
        native = self.spec.wire == "native"
        seen: set[str] = set()
        for topic in (t.imu, t.mag, t.baro, t.gps):
            if topic in seen:
                continue
            seen.add(topic)
            if not native:
                self._subs.append((ctx.subscribe(topic, MavlinkPacket), False))
            else:
                tp: type[Any] = HilGps if topic == t.gps else HilSensor
                self._subs.append((ctx.subscribe(topic, tp), True))
        self._uplink = ctx.subscribe(self.spec.uplink, MavlinkPacket)

    def step(self, ctx: StepContext) -> None:
        """One autopilot cycle: sensors, ground station, commander, navigator, control."""
        self._now = ctx.time
        for sub, native in self._subs:
            if sub._deliveries:
                for payload in sub.messages:
                    if native:
                        self._sensor(payload)
                    else:
                        for m in unpack(payload):
                            self._sensor(m)
        up = self._uplink
        if up is not None and up._deliveries:
            for packet in up.messages:
                for m in decode_frames(self.mav, packet.data):
                    self._handle(m)
        if self._upload is not None:
            self._upload_tick()
        self._commander()
        out = self._navigate_and_control()
        ctx.publish(self.spec.topics.actuators, pack(out) if self.spec.wire == "mavlink" else out)
        self._stream()
        if self._out:
            ctx.publish(self.spec.downlink, MavlinkPacket(b"".join(self._out)))
            self._out = []

    def _sensor(self, m: Any) -> None:
        now = m.time_usec * 1e-6
        if type(m) is HilGps:
            self.est.gps(
                now,
                m.lat,
                m.lon,
                m.alt,
                (m.vn, m.ve, m.vd),
                m.fix_type,
                m.satellites_visible,
                m.eph,
                m.epv,
            )
            return
        f = m.fields_updated
        if f & IMU_FIELDS == IMU_FIELDS:
            last = self._last_imu_us
            dt = (m.time_usec - last) * 1e-6 if last is not None else 0.0
            self._last_imu_us = m.time_usec
            self.est.imu(now, dt, (m.xacc, m.yacc, m.zacc), (m.xgyro, m.ygyro, m.zgyro))
        if f & MAG_FIELDS == MAG_FIELDS:
            self.est.mag(now, (m.xmag, m.ymag, m.zmag))
        if f & BARO_FIELDS & 0x800:
            self.est.baro(now, m.pressure_alt)

    # -- commander --------------------------------------------------------------------------

    def _text(self, text: str, severity: int = SEV_INFO) -> None:
        self._send(self._d.MAVLink_statustext_message(severity, text.encode()[:50], 0, 0))

    def arm_check(self) -> str | None:
        """Why arming would be refused now, or None (PX4's preflight checks, simplified)."""
        now, est = self._now, self.est
        if now - est.last_imu > 0.5 or not est.attitude_ok:
            return "Preflight Fail: accel/gyro not ready"
        if now - est.last_mag > 1.0:
            return "Preflight Fail: no magnetometer"
        if now - est.last_baro > 1.0:
            return "Preflight Fail: no barometer"
        if not est.gps_ok(now):
            return "Preflight Fail: GPS fix too low"
        if not est.position_ok(now):
            return "Preflight Fail: position estimate not valid"
        if self.mode == Mode.MISSION and not self.mission:
            return "Arming denied: no mission"
        return None

    def arm(self, force: bool = False) -> str | None:
        """Arm (unless a check fails: its reason is returned and sent as STATUSTEXT)."""
        if self.armed:
            return None
        reason = None if force else self.arm_check()
        if reason is not None:
            self._text(reason, SEV_CRITICAL)
            return reason
        self.armed = True
        self._armed_at = self._now
        self._flew = False
        self.failsafe = None
        self._set_home()
        self._hold = tuple(self.est.pos)  # type: ignore[assignment]
        self._ground_d = self.est.pos[2]
        self._text("Armed by external command")
        self._dirty.add("HEARTBEAT")
        if self.mode == Mode.MISSION:
            self._start_mission_item()
        return None

    def disarm(self, force: bool = False) -> str | None:
        """Disarm; refused in the air unless forced."""
        if not self.armed:
            return None
        if not self.landed and not force:
            self._text("Disarming denied: not landed", SEV_CRITICAL)
            return "not landed"
        self.armed = False
        self.ctl.reset()
        self._text("Disarmed")
        self._dirty.update(("HEARTBEAT", "EXTENDED_SYS_STATE"))
        return None

    def _set_home(self) -> None:
        est = self.est
        if est.origin is None:
            return
        lat, lon, alt = est.global_position()
        self.home = (est.pos[0], est.pos[1], est.pos[2], lat, lon, alt)
        self._dirty.add("HOME_POSITION")

    def set_mode(self, mode: Mode) -> str | None:
        """Switch flight mode; returns why it was refused, or None."""
        if mode in (Mode.MISSION, Mode.RTL, Mode.TAKEOFF, Mode.POSCTL) and not (
            self.est.position_ok(self._now)
        ):
            return "no valid position"
        if mode == Mode.MISSION and not self.mission:
            return "no mission"
        if mode in (Mode.RTL,) and self.home is None:
            return "no home position"
        if mode == self.mode and mode != Mode.MISSION:
            return None
        self.mode = mode
        self._phase = ""
        self._target = None
        if not self.landed:
            self._hold = tuple(self.est.pos)  # type: ignore[assignment]
        if mode == Mode.MISSION:
            if self.seq >= len(self.mission):
                self.seq = 0
            self.mission_state = MISSION_STATE_ACTIVE
            self._start_mission_item()
            self._dirty.add("MISSION_CURRENT")
        elif self.mission_state == MISSION_STATE_ACTIVE:
            self.mission_state = MISSION_STATE_PAUSED
            self._dirty.add("MISSION_CURRENT")
        self._dirty.add("HEARTBEAT")
        return None

    def _commander(self) -> None:
        now, est = self._now, self.est
        if self.home is None and est.position_ok(now):
            self._set_home()
        if not self.armed:
            return
        # GPS-loss failsafe: without position, the only safe action is to descend.
        if (
            not self.landed
            and self.failsafe is None
            and (now - est.last_gps > self.params["COM_POS_FS_DELAY"] or est.gps_fix < 3)
        ):
            self.failsafe = "GPS lost"
            self._text("Failsafe: GPS lost, landing", SEV_CRITICAL)
            self.mode = Mode.LAND
            self._phase = ""
            self._dirty.add("HEARTBEAT")
        # Land detector: asked to descend, but not moving down (the ground holds it).
        if self.landed:
            if est.pos[2] < self._ground_d - 0.4:
                self.landed = False
                self._flew = True
                self._touch_since = None
                self._dirty.add("EXTENDED_SYS_STATE")
        elif self._vz_sp > 0.2 and abs(est.vel[2]) < 0.15:
            if self._touch_since is None:
                self._touch_since = now
            elif now - self._touch_since > 1.0:
                self.landed = True
                self._landed_at = now
                self._ground_d = est.pos[2]
                self._hold = tuple(est.pos)  # type: ignore[assignment]
                self._dirty.add("EXTENDED_SYS_STATE")
                self._text("Landing detected")
                if (
                    self.mode == Mode.MISSION
                    and self.seq < len(self.mission)
                    and (self.mission[self.seq].command in (CMD_LAND, CMD_RTL))
                ):
                    self._item_reached()
        else:
            self._touch_since = None
        if self.landed:
            delay = self.params["COM_DISARM_LAND"]
            if (
                self._flew
                and delay >= 0
                and self._landed_at is not None
                and (now - self._landed_at >= delay)
            ):
                self.disarm()
                if self.mode in (Mode.LAND, Mode.RTL) or (
                    self.mode == Mode.MISSION and self.seq >= len(self.mission)
                ):
                    self.mode = Mode.LOITER
                    self._dirty.add("HEARTBEAT")
            prflt = self.params["COM_DISARM_PRFLT"]
            if (
                not self._flew
                and prflt > 0
                and now - self._armed_at > prflt
                and (self.mode in (Mode.LOITER, Mode.POSCTL))
            ):
                self._text("Disarmed: no takeoff", SEV_NOTICE)
                self.disarm()

    # -- navigator --------------------------------------------------------------------------

    def _home_d(self) -> float:
        return self.home[2] if self.home is not None else self._ground_d

    def _item_target(self, item: Item) -> tuple[float, float, float]:
        """Local NED target of a global mission item (current position where lat/lon = 0)."""
        est = self.est
        if (item.x == 0 and item.y == 0) or est.origin is None:
            n, e = est.pos[0], est.pos[1]
        else:
            n, e = est.origin.project(item.x * 1e-7, item.y * 1e-7)
        if item.frame in (FRAME_GLOBAL, FRAME_GLOBAL_INT):
            d = -(item.z - est.origin_alt)
        else:
            d = self._home_d() - item.z
        return n, e, d

    def _start_mission_item(self) -> None:
        self._phase = ""
        self._target = None
        self._reached_at = None
        while (
            self.seq < len(self.mission) and self.mission[self.seq].command == CMD_DO_CHANGE_SPEED
        ):
            item = self.mission[self.seq]
            if item.param2 > 0:
                self._cruise = item.param2
            self._item_reached()

    def _item_reached(self) -> None:
        self._send(self._d.MAVLink_mission_item_reached_message(self.seq))
        self.seq += 1
        self._phase = ""
        self._target = None
        self._reached_at = None
        self._dirty.add("MISSION_CURRENT")
        if self.seq >= len(self.mission):
            self.mission_state = MISSION_STATE_COMPLETE
            self._text("Mission finished")
        else:
            item = self.mission[self.seq]
            if item.command == CMD_DO_CHANGE_SPEED:
                self._start_mission_item()

    def _land_speed(self) -> float:
        height = self._home_d() - self.est.pos[2]
        if height > self.params["MPC_LAND_ALT2"]:
            return self.params["MPC_Z_VEL_MAX_DN"]
        return self.params["MPC_LAND_SPEED"]

    def _setpoint(self) -> tuple[tuple[float, float, float], float | None, bool]:
        """(position setpoint, vertical-speed override, idle) for the current mode."""
        est, p = self.est, self.params
        pos = est.pos
        mode = self.mode
        if self.landed and not self._wants_takeoff():
            return (pos[0], pos[1], pos[2]), None, True
        if mode in (Mode.LOITER, Mode.POSCTL):
            return self._hold, None, False
        if mode == Mode.TAKEOFF:
            if self._target is None:
                alt = max(p["MIS_TAKEOFF_ALT"], 1.0)
                self._target = (self._hold[0], self._hold[1], self._home_d() - alt)
            t = self._target
            if abs(pos[2] - t[2]) < p["NAV_MC_ALT_RAD"]:
                self._text("Takeoff complete")
                self.mode = Mode.LOITER
                self._hold = t
                self._dirty.add("HEARTBEAT")
            return t, None, False
        if mode == Mode.LAND:
            return self._hold, self._land_speed(), False
        if mode == Mode.RTL:
            return self._rtl()
        return self._mission()

    def _wants_takeoff(self) -> bool:
        if not self.armed:
            return False
        if self.mode == Mode.TAKEOFF:
            return True
        return (
            self.mode == Mode.MISSION
            and self.seq < len(self.mission)
            and (self.mission[self.seq].command not in (CMD_LAND, CMD_RTL))
        )

    def _rtl(self) -> tuple[tuple[float, float, float], float | None, bool]:
        est, p = self.est, self.params
        pos = est.pos
        home = self.home or (pos[0], pos[1], pos[2])
        if not self._phase:
            alt = max(p["RTL_RETURN_ALT"], home[2] - pos[2])
            self._target = (pos[0], pos[1], home[2] - alt)
            self._phase = "climb"
            self._text("RTL: climbing")
        t = self._target
        assert t is not None
        if self._phase == "climb":
            if abs(pos[2] - t[2]) < p["NAV_MC_ALT_RAD"]:
                self._phase = "return"
                self._target = (home[0], home[1], t[2])
            return t, None, False
        if self._phase == "return":
            if math.hypot(pos[0] - t[0], pos[1] - t[1]) < p["NAV_ACC_RAD"]:
                self._phase = "land"
                self._hold = (t[0], t[1], t[2])
                self._text("RTL: landing at home")
            return t, None, False
        return self._hold, self._land_speed(), False

    def _mission(self) -> tuple[tuple[float, float, float], float | None, bool]:
        est, p = self.est, self.params
        pos = est.pos
        if self.seq >= len(self.mission):
            if self._phase != "done":
                self._phase = "done"
                self._hold = tuple(pos)  # type: ignore[assignment]
            return self._hold, None, False
        item = self.mission[self.seq]
        cmd = item.command
        if cmd == CMD_RTL:
            sp = self._rtl()
            if self.landed:
                self._item_reached()
            return sp
        if self._target is None:
            self._target = self._item_target(item)
            if cmd == CMD_TAKEOFF:
                self._target = (pos[0], pos[1], self._target[2])
        t = self._target
        if self.landed and self._phase == "":
            # On the ground with a mission to fly: take off first (PX4 does the same when
            # the mission does not begin with a takeoff item).
            alt = max(p["MIS_TAKEOFF_ALT"], self._home_d() - t[2], 1.0)
            self._hold = (pos[0], pos[1], self._home_d() - alt)
            self._phase = "takeoff"
        if self._phase == "takeoff":
            if abs(pos[2] - self._hold[2]) < p["NAV_MC_ALT_RAD"]:
                self._phase = "go"
                if cmd == CMD_TAKEOFF:
                    self._item_reached()
                    return self._hold, None, False
            else:
                return self._hold, None, False
        if cmd == CMD_LAND:
            if self._phase in ("", "go"):
                target = (t[0], t[1], pos[2]) if self._phase == "" else t
                self._phase = "approach"
                self._target = (target[0], target[1], pos[2])
                t = self._target
            if self._phase == "approach":
                if math.hypot(pos[0] - t[0], pos[1] - t[1]) < p["NAV_ACC_RAD"]:
                    self._phase = "descend"
                    self._hold = t
                return t, None, False
            if self.landed:
                self._item_reached()
            return self._hold, self._land_speed(), False
        # Waypoint (or takeoff when already airborne, or unlimited loiter).
        acc = item.param2 if cmd == CMD_WAYPOINT and item.param2 > 0 else p["NAV_ACC_RAD"]
        hdist = math.hypot(pos[0] - t[0], pos[1] - t[1])
        if cmd != CMD_LOITER_UNLIM and hdist < acc and abs(pos[2] - t[2]) < p["NAV_MC_ALT_RAD"]:
            hold_time = item.param1 if cmd == CMD_WAYPOINT else 0.0
            if self._reached_at is None:
                self._reached_at = self._now
            if self._now - self._reached_at >= hold_time:
                self._hold = t
                self._item_reached()
                return t, None, False
        if hdist > 2.0:
            self._yaw_sp = math.atan2(t[1] - pos[1], t[0] - pos[0])
        return t, None, False

    def _navigate_and_control(self) -> HilActuatorControls:
        est, p = self.est, self.params
        t_us = round(self._now * 1e6)
        if not self.armed:
            self._vz_sp = 0.0
            self._pos_sp = self._vel_sp = None
            return HilActuatorControls(t_us, _ZEROS16, 0, 1)
        sp, vz_override, idle = self._setpoint()
        self._pos_sp, self._vel_sp = sp, None
        cruise = self._cruise or p["MPC_XY_CRUISE"]
        up = (
            p["MPC_TKO_SPEED"]
            if self.landed or self.mode == Mode.TAKEOFF
            else p["MPC_Z_VEL_MAX_UP"]
        )
        if idle:
            self._vz_sp = 0.0
            self.ctl.reset()
            if self.velocity_vehicle:
                return HilActuatorControls(
                    t_us,
                    [0.0, 0.0, 0.0, self._yaw_sp, *_ZEROS12],
                    ARMED_FLAG,
                    ACTUATOR_FLAG_VELOCITY | 1,
                )
            return HilActuatorControls(t_us, [0.1, 0.1, 0.1, 0.1, *_ZEROS12], ARMED_FLAG, 1)
        vel_sp = position_control(
            est.pos,
            sp,
            cruise=cruise,
            up=up,
            down=p["MPC_Z_VEL_MAX_DN"],
            vz_override=vz_override,
        )
        if self.failsafe is not None or not est.position_ok(self._now):
            vel_sp = (0.0, 0.0, vel_sp[2])  # no position: hold still horizontally
        self._vz_sp = vel_sp[2]
        self._vel_sp = vel_sp
        if self.velocity_vehicle:
            return HilActuatorControls(
                t_us,
                [vel_sp[0], vel_sp[1], vel_sp[2], self._yaw_sp, *_ZEROS12],
                ARMED_FLAG,
                ACTUATOR_FLAG_VELOCITY | 1,
            )
        motors = self.ctl.update(
            self.period, est.vel, vel_sp, self._yaw_sp, est.rotation(), est.rates
        )
        return HilActuatorControls(t_us, [*motors, *_ZEROS12], ARMED_FLAG, 1)

    # -- ground-station link: dispatch ------------------------------------------------------

    def _send(self, msg: Any) -> None:
        mav = self.mav
        self._out.append(bytes(msg.pack(mav)))
        mav.seq = (mav.seq + 1) & 0xFF

    def _handle(self, m: Any) -> None:
        name = m.get_type()
        target = getattr(m, "target_system", None)
        if target not in (None, 0, self.spec.system_id):
            return
        handler = getattr(self, "_on_" + name.lower(), None)
        if handler is not None:
            self._gcs = (m.get_srcSystem(), m.get_srcComponent())
            try:
                handler(m)
            except Exception:
                # Flight software must not fall over on a malformed request.
                log.warning("ignored a malformed %s", name, exc_info=True)

    def _on_heartbeat(self, m: Any) -> None:
        pass  # a ground station is present; we talk to whoever talks to us

    def _on_timesync(self, m: Any) -> None:
        if m.tc1 == 0:
            self._send(self._d.MAVLink_timesync_message(round(self._now * 1e9), m.ts1))

    def _on_command_long(self, m: Any) -> None:
        result = self._command(
            m.command, (m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7)
        )
        src_sys, src_comp = self._gcs
        self._send(self._d.MAVLink_command_ack_message(m.command, result, 0, 0, src_sys, src_comp))
        for msg in self._after_ack:
            self._send(msg)
        self._after_ack.clear()

    def _on_command_int(self, m: Any) -> None:
        result = RESULT_UNSUPPORTED
        if m.command in (CMD_RTL, CMD_LAND, CMD_MISSION_START, CMD_DO_SET_MODE, CMD_ARM_DISARM):
            result = self._command(
                m.command, (m.param1, m.param2, m.param3, m.param4, m.x * 1e-7, m.y * 1e-7, m.z)
            )
        src_sys, src_comp = self._gcs
        self._send(self._d.MAVLink_command_ack_message(m.command, result, 0, 0, src_sys, src_comp))

    def _command(self, cmd: int, p: tuple[float, ...]) -> int:
        if cmd == CMD_ARM_DISARM:
            force = _int(p[1]) == FORCE_MAGIC
            if p[0] > 0.5:
                return RESULT_ACCEPTED if self.arm(force) is None else RESULT_DENIED
            return RESULT_ACCEPTED if self.disarm(force) is None else RESULT_DENIED
        if cmd == CMD_DO_SET_MODE:
            if not _int(p[0]) & MODE_FLAG_CUSTOM:
                return RESULT_UNSUPPORTED
            mode = Mode.from_custom(_int(p[1]), _int(p[2]))
            if mode is None:
                return RESULT_UNSUPPORTED
            return self._mode_result(mode)
        if cmd == CMD_MISSION_START:
            if self.mission and 0 <= _int(p[0]) < len(self.mission):
                self.seq = _int(p[0])
            return self._mode_result(Mode.MISSION)
        if cmd == CMD_TAKEOFF:
            if not self.armed:
                return RESULT_DENIED
            alt = p[6]
            if math.isfinite(alt) and self.home is not None:
                self.params["MIS_TAKEOFF_ALT"] = max(1.0, alt - self.home[5])
            return self._mode_result(Mode.TAKEOFF)
        if cmd == CMD_LAND:
            return self._mode_result(Mode.LAND)
        if cmd == CMD_RTL:
            return self._mode_result(Mode.RTL)
        if cmd == CMD_GET_HOME:
            if self.home is None:
                return RESULT_TEMP_REJECTED
            self._dirty.add("HOME_POSITION")
            return RESULT_ACCEPTED
        if cmd in (CMD_REQUEST_MESSAGE, CMD_REQUEST_CAPABILITIES):
            msgid = 148 if cmd == CMD_REQUEST_CAPABILITIES else _int(p[0])
            return self._request_message(msgid)
        if cmd == CMD_SET_MSG_INTERVAL:
            return self._set_interval(_int(p[0]), p[1] if math.isfinite(p[1]) else 0.0)
        return RESULT_UNSUPPORTED

    def _mode_result(self, mode: Mode) -> int:
        reason = self.set_mode(mode)
        if reason is None:
            return RESULT_ACCEPTED
        self._text(f"Mode {mode.label} denied: {reason}", SEV_WARNING)
        return RESULT_DENIED

    def _request_message(self, msgid: int) -> int:
        cls = self._d.mavlink_map.get(msgid)
        if cls is None:
            return RESULT_UNSUPPORTED
        name = cls.msgname
        if name == "AUTOPILOT_VERSION":
            self._after_ack.append(self._autopilot_version())  # the answer follows the ACK
            return RESULT_ACCEPTED
        if name == "HOME_POSITION" and self.home is None:
            return RESULT_TEMP_REJECTED
        if name in self._streams:
            self._dirty.add(name)
            return RESULT_ACCEPTED
        return RESULT_UNSUPPORTED

    def _set_interval(self, msgid: int, interval_us: float) -> int:
        cls = self._d.mavlink_map.get(msgid)
        if cls is None or cls.msgname not in self._streams:
            return RESULT_UNSUPPORTED
        name = cls.msgname
        if interval_us == 0:
            per = STREAM_DEFAULTS[name]
            self._streams[name][0] = per if per is not None else 1.0 / self.spec.telemetry_rate
        elif interval_us < 0:
            self._streams[name][0] = math.inf
        else:
            self._streams[name][0] = max(interval_us * 1e-6, self.period)
        self._streams[name][1] = self._now
        self._next_due = self._now
        return RESULT_ACCEPTED

    # -- parameter protocol -----------------------------------------------------------------

    def _param_value(self, name: str) -> None:
        names = self.params.names
        self._send(
            self._d.MAVLink_param_value_message(
                name.encode(), self.params[name], PARAM_REAL32, len(names), names.index(name)
            )
        )

    def _on_param_request_list(self, m: Any) -> None:
        for name in self.params.names:
            self._param_value(name)

    def _on_param_request_read(self, m: Any) -> None:
        names = self.params.names
        name = _param_name(m.param_id)
        if m.param_index >= 0:
            if m.param_index < len(names):
                self._param_value(names[m.param_index])
        elif name in self.params:
            self._param_value(name)

    def _on_param_set(self, m: Any) -> None:
        name = _param_name(m.param_id)
        if name not in self.params:
            self._text(f"Unknown parameter {name}", SEV_WARNING)
            return
        if not self.params.set(name, m.param_value):
            self._text(f"Parameter {name} out of range", SEV_WARNING)
        self._param_value(name)  # the echo tells the sender the value now in effect

    # -- mission protocol -------------------------------------------------------------------

    def _mission_ack(self, result: int, mission_type: int = MISSION_TYPE_MISSION) -> None:
        s, c = self._gcs
        self._send(self._d.MAVLink_mission_ack_message(s, c, result, mission_type))

    def _on_mission_count(self, m: Any) -> None:
        mtype = getattr(m, "mission_type", 0)
        if mtype != MISSION_TYPE_MISSION:
            # Geofence and rally points are not stored; an empty list is accepted.
            self._mission_ack(MISSION_ACCEPTED if m.count == 0 else MISSION_UNSUPPORTED, mtype)
            return
        if m.count == 0:
            self._clear_mission()
            self._mission_ack(MISSION_ACCEPTED)
            return
        self._upload = {"count": m.count, "items": [], "tries": 0, "deadline": 0.0}
        self._request_item()

    def _request_item(self) -> None:
        up = self._upload
        assert up is not None
        s, c = self._gcs
        self._send(self._d.MAVLink_mission_request_int_message(s, c, len(up["items"]), 0))
        up["deadline"] = self._now + 0.5
        up["tries"] += 1

    def _upload_tick(self) -> None:
        up = self._upload
        assert up is not None
        if self._now < up["deadline"]:
            return
        if up["tries"] >= 5:
            self._upload = None
            self._mission_ack(MISSION_OPERATION_CANCELLED)
            self._text("Mission upload timed out", SEV_WARNING)
            return
        self._request_item()

    def _on_mission_item_int(self, m: Any) -> None:
        up = self._upload
        if up is None or getattr(m, "mission_type", 0) != MISSION_TYPE_MISSION:
            return
        if m.seq != len(up["items"]):
            if m.seq < len(up["items"]):
                return  # a duplicate: our request crossed it; the next one is on its way
            self._upload = None
            self._mission_ack(MISSION_INVALID_SEQUENCE)
            return
        up["items"].append(
            Item(
                m.seq,
                m.frame,
                m.command,
                m.current,
                m.autocontinue,
                m.param1,
                m.param2,
                m.param3,
                m.param4,
                m.x,
                m.y,
                m.z,
            )
        )
        up["tries"] = 0
        if len(up["items"]) < up["count"]:
            self._request_item()
            return
        self._upload = None
        items: list[Item] = up["items"]
        result, why = self._check_mission(items)
        if result != MISSION_ACCEPTED:
            self._text(f"Mission rejected: {why}", SEV_CRITICAL)
            self._mission_ack(result)
            return
        self.mission = items
        self.seq = 0
        self.mission_state = MISSION_STATE_NOT_STARTED
        self._cruise = None
        if self.mode == Mode.MISSION:
            self._start_mission_item()
        self._dirty.add("MISSION_CURRENT")
        self._mission_ack(MISSION_ACCEPTED)

    def _on_mission_item(self, m: Any) -> None:
        # The deprecated float variant: same fields, degrees instead of degE7.
        int_frame = {FRAME_GLOBAL: FRAME_GLOBAL_INT, FRAME_GLOBAL_REL: FRAME_GLOBAL_REL_INT}
        self._on_mission_item_int(_FloatItem(m, int_frame.get(m.frame, m.frame)))

    def _check_mission(self, items: list[Item]) -> tuple[int, str]:
        fence_r = self.params["GF_MAX_HOR_DIST"]
        fence_h = self.params["GF_MAX_VER_DIST"]
        ref = self.home
        proj = LocalProjection(ref[3], ref[4]) if ref is not None else None
        for it in items:
            if it.command not in NAV_COMMANDS and it.command != CMD_DO_CHANGE_SPEED:
                return MISSION_UNSUPPORTED, f"item {it.seq}: command {it.command} unsupported"
            if it.command in NAV_COMMANDS and it.frame not in (
                FRAME_GLOBAL,
                FRAME_GLOBAL_REL,
                FRAME_GLOBAL_INT,
                FRAME_GLOBAL_REL_INT,
                # PX4 takes a return-to-launch item (no position) in the mission frame.
                *((FRAME_MISSION,) if it.command == CMD_RTL else ()),
            ):
                return MISSION_UNSUPPORTED_FRAME, f"item {it.seq}: frame {it.frame} unsupported"
            if it.command in (CMD_WAYPOINT, CMD_LOITER_UNLIM, CMD_LAND) and (
                abs(it.x) > 900_000_000 or abs(it.y) > 1_800_000_000
            ):
                return MISSION_INVALID, f"item {it.seq}: coordinates out of range"
            if (
                proj is not None
                and ref is not None
                and it.command in NAV_COMMANDS
                and (it.x or it.y)
            ):
                n, e = proj.project(it.x * 1e-7, it.y * 1e-7)
                if fence_r > 0 and math.hypot(n, e) > fence_r:
                    return MISSION_ERROR, f"item {it.seq} outside geofence"
                rel = it.z - ref[5] if it.frame in (FRAME_GLOBAL, FRAME_GLOBAL_INT) else it.z
                if fence_h > 0 and rel > fence_h:
                    return MISSION_ERROR, f"item {it.seq} above geofence"
        return MISSION_ACCEPTED, ""

    def _clear_mission(self) -> None:
        self.mission = []
        self.seq = 0
        self.mission_state = MISSION_STATE_NO_MISSION
        if self.mode == Mode.MISSION:
            self.set_mode(Mode.LOITER)
        self._dirty.add("MISSION_CURRENT")

    def _on_mission_clear_all(self, m: Any) -> None:
        mtype = getattr(m, "mission_type", 0)
        if mtype == MISSION_TYPE_MISSION:
            self._clear_mission()
        self._mission_ack(MISSION_ACCEPTED, mtype)

    def _on_mission_request_list(self, m: Any) -> None:
        mtype = getattr(m, "mission_type", 0)
        count = len(self.mission) if mtype == MISSION_TYPE_MISSION else 0
        s, c = self._gcs
        self._send(self._d.MAVLink_mission_count_message(s, c, count, mtype))

    def _on_mission_request_int(self, m: Any) -> None:
        if getattr(m, "mission_type", 0) != MISSION_TYPE_MISSION or not (
            0 <= m.seq < len(self.mission)
        ):
            self._mission_ack(MISSION_INVALID_SEQUENCE, getattr(m, "mission_type", 0))
            return
        it = self.mission[m.seq]
        s, c = self._gcs
        self._send(
            self._d.MAVLink_mission_item_int_message(
                s,
                c,
                it.seq,
                it.frame,
                it.command,
                int(it.seq == self.seq),
                it.autocontinue,
                it.param1,
                it.param2,
                it.param3,
                it.param4,
                it.x,
                it.y,
                it.z,
                0,
            )
        )

    _on_mission_request = _on_mission_request_int

    def _on_mission_set_current(self, m: Any) -> None:
        if 0 <= m.seq < len(self.mission):
            self.seq = m.seq
            self._start_mission_item()
            self._dirty.add("MISSION_CURRENT")

    # -- telemetry --------------------------------------------------------------------------

    def _stream(self) -> None:
        now = self._now
        dirty = self._dirty
        # A tolerance of 1 us: float sums of the period must not slip a sample to the next step.
        now += 1e-6
        if now < self._next_due and not dirty:
            return
        next_due = math.inf
        for name, slot, build in self._stream_list:
            due = now >= slot[1]
            if due or name in dirty:
                if name == "HOME_POSITION" and self.home is None:
                    continue
                if due:
                    # Keep a fixed grid on the simulated clock (no drift, deterministic).
                    slot[1] = max(slot[1] + slot[0], now) if slot[0] != math.inf else math.inf
                msg = build()
                if type(msg) is bytes:
                    self._out.append(msg)
                else:
                    self._send(msg)
            if slot[1] < next_due:
                next_due = slot[1]
        self._next_due = next_due
        dirty.clear()

    def _base_mode(self) -> int:
        main = self.mode.value[0]
        flags = MODE_FLAG_CUSTOM | MODE_FLAG_STABILIZE
        flags |= (
            MODE_FLAG_AUTO | MODE_FLAG_GUIDED
            if main == MainMode.AUTO
            else (MODE_FLAG_MANUAL | MODE_FLAG_GUIDED)
        )
        return flags | (MODE_FLAG_ARMED if self.armed else 0)

    def _msg_heartbeat(self) -> Any:
        state = (
            MAV_STATE_CRITICAL
            if self.failsafe
            else (MAV_STATE_ACTIVE if self.armed else MAV_STATE_STANDBY)
        )
        return self._d.MAVLink_heartbeat_message(
            MAV_TYPE_QUADROTOR,
            MAV_AUTOPILOT_PX4,
            self._base_mode(),
            self.mode.custom_mode,
            state,
            3,
        )

    def _msg_sys_status(self) -> Any:
        now, est = self._now, self.est
        health = 0
        if now - est.last_imu < 0.5:
            health |= 1 | 2
        if now - est.last_mag < 1.0:
            health |= 4
        if now - est.last_baro < 1.0:
            health |= 8
        if est.gps_ok(now):
            health |= 32
        if est.attitude_ok:
            health |= AHRS_BIT
        health |= CONTROL_BITS
        present = SENSOR_BITS | CONTROL_BITS | AHRS_BIT | PREARM_BIT
        if self.armed or self.arm_check() is None:
            health |= PREARM_BIT
        return self._d.MAVLink_sys_status_message(
            present,
            present,
            health,
            250,
            16200,
            -1,
            100,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    def _msg_extended_sys_state(self) -> Any:
        if self.landed:
            state = LANDED_ON_GROUND
        elif self._vz_sp > 0.2 and self.mode in (Mode.LAND, Mode.RTL):
            state = LANDED_LANDING
        elif self.mode == Mode.TAKEOFF or self._phase == "takeoff":
            state = LANDED_TAKEOFF
        else:
            state = LANDED_IN_AIR
        return self._d.MAVLink_extended_sys_state_message(0, state)

    def _msg_home_position(self) -> Any:
        h = self.home
        assert h is not None
        return self._d.MAVLink_home_position_message(
            round(h[3] * 1e7),
            round(h[4] * 1e7),
            round(h[5] * 1000),
            h[0],
            h[1],
            h[2],
            [1.0, 0.0, 0.0, 0.0],
            0.0,
            0.0,
            0.0,
            round(self._now * 1e6),
        )

    def _msg_mission_current(self) -> Any:
        state = self.mission_state if self.mission else MISSION_STATE_NO_MISSION
        in_mission = 1 if self.mode == Mode.MISSION else 2
        seq = min(self.seq, max(len(self.mission) - 1, 0))
        return self._d.MAVLink_mission_current_message(seq, len(self.mission), state, in_mission)

    def _msg_position_target_local_ned(self) -> bytes:
        pos, vel = self._pos_sp, self._vel_sp
        mask = TARGET_IGNORE_ACCEL | TARGET_IGNORE_YAW_RATE
        if pos is None:
            pos, mask = _NANS3, mask | TARGET_IGNORE_POSITION
        if vel is None:
            vel, mask = _NANS3, mask | TARGET_IGNORE_VELOCITY
        return pack_scalar(
            self.mav,
            self._d.MAVLink_position_target_local_ned_message,
            round(self._now * 1000),
            *pos,
            *vel,
            0.0,
            0.0,
            0.0,
            self._yaw_sp if self.armed else math.nan,
            0.0,
            mask,
            FRAME_LOCAL_NED,
        )

    def _msg_gps_raw_int(self) -> Any:
        est = self.est
        lat, lon, alt, eph, epv, vel, cog = est.gps_raw
        return self._d.MAVLink_gps_raw_int_message(
            round(self._now * 1e6),
            est.gps_fix,
            lat,
            lon,
            alt,
            eph,
            epv,
            vel,
            cog,
            est.gps_sats,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    # The three high-rate streams are packed directly (byte-identical to pymavlink's pack);
    # their builders return the frame, which _stream passes through.

    def _msg_global_position_int(self) -> bytes:
        est = self.est
        lat, lon, alt = est.global_position()
        vel = est.vel
        home_alt = self.home[5] if self.home is not None else est.origin_alt
        hdg = round(math.degrees(est.euler()[2]) * 100) % 36000
        return pack_scalar(
            self.mav,
            self._d.MAVLink_global_position_int_message,
            round(self._now * 1000),
            round(lat * 1e7),
            round(lon * 1e7),
            round(alt * 1000),
            round((alt - home_alt) * 1000),
            round(vel[0] * 100),
            round(vel[1] * 100),
            round(vel[2] * 100),
            hdg,
        )

    def _msg_local_position_ned(self) -> bytes:
        pos, vel = self.est.pos, self.est.vel
        return pack_scalar(
            self.mav,
            self._d.MAVLink_local_position_ned_message,
            round(self._now * 1000),
            pos[0],
            pos[1],
            pos[2],
            vel[0],
            vel[1],
            vel[2],
        )

    def _msg_attitude(self) -> bytes:
        roll, pitch, yaw = self.est.euler()
        r = self.est.rates
        return pack_scalar(
            self.mav,
            self._d.MAVLink_attitude_message,
            round(self._now * 1000),
            roll,
            pitch,
            yaw,
            r[0],
            r[1],
            r[2],
        )

    def _autopilot_version(self) -> Any:
        return self._d.MAVLink_autopilot_version_message(
            CAPABILITIES,
            FLIGHT_SW_VERSION,
            0,
            0,
            0,
            [0] * 8,
            [0] * 8,
            [0] * 8,
            0x26AC,
            0x11,
            0x4D43534D,
            [0] * 18,
        )


_ZEROS12 = [0.0] * 12
_NANS3 = (math.nan, math.nan, math.nan)
_ZEROS16 = [0.0] * 16


def _int(x: float) -> int:
    """``x`` rounded, with NaN and infinities (\"unset\" in MAVLink) as 0."""
    return round(x) if math.isfinite(x) else 0


def _param_name(raw: Any) -> str:
    text = raw.decode(errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.split("\0", 1)[0]


class _FloatItem:
    """A MISSION_ITEM seen as a MISSION_ITEM_INT."""

    def __init__(self, m: Any, frame: int) -> None:
        self.__dict__.update({k: getattr(m, k) for k in m.get_fieldnames()})
        self.frame = frame
        self.x = round(m.x * 1e7)
        self.y = round(m.y * 1e7)


def autopilot(spec: AutopilotSpec) -> Autopilot:
    """Factory for ``multicosim participant multicosim.px4._autopilot:autopilot --config``."""
    return Autopilot(spec)


__all__ += ["Item", "MainMode", "SubMode"]
