"""Telemetry streams: which messages the autopilot sends, how often, and their contents.

Two profiles, as PX4 has link modes: ``gcs`` (what the in-process ground station reads,
kept lean for speed) and ``onboard`` (the messages and rates real PX4 v1.15.4 sends on its
API link, as recorded in ``conformance``'s data; what ``multicosim px4 sitl`` sends).
SET_MESSAGE_INTERVAL changes any rate, REQUEST_MESSAGE sends one at once.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

from ...mavlink.dialect import (
    AHRS_BIT,
    FRAME_LOCAL_NED,
    LANDED_IN_AIR,
    LANDED_LANDING,
    LANDED_ON_GROUND,
    LANDED_TAKEOFF,
    MAV_AUTOPILOT_PX4,
    MAV_STATE_ACTIVE,
    MAV_STATE_CRITICAL,
    MAV_STATE_STANDBY,
    MAV_TYPE_QUADROTOR,
    MISSION_STATE_NO_MISSION,
    MODE_FLAG_ARMED,
    MODE_FLAG_AUTO,
    MODE_FLAG_CUSTOM,
    MODE_FLAG_GUIDED,
    MODE_FLAG_MANUAL,
    MODE_FLAG_STABILIZE,
    PREARM_BIT,
    TARGET_IGNORE_ACCEL,
    TARGET_IGNORE_POSITION,
    TARGET_IGNORE_VELOCITY,
    TARGET_IGNORE_YAW_RATE,
    dialect,
    pack_scalar,
)
from ..modes import MainMode, Mode
from .state import State

__all__ = ["GCS_STREAMS", "Streams", "onboard_streams"]

SENSOR_BITS = 1 | 2 | 4 | 8 | 32  # gyro, accel, mag, baro, GPS
CONTROL_BITS = 1024 | 2048 | 4096 | 8192 | 16384 | 32768  # rate..xy control, motor outputs
CAPABILITIES = 1 | 2 | 4 | 8 | 256 | 8192  # mission float/int, param float, cmd int, ftp-less
FLIGHT_SW_VERSION = (1 << 24) | (15 << 16) | (4 << 8) | 255  # "v1.15.4 official", as PX4's
_NANS3 = (math.nan, math.nan, math.nan)
NOMINAL_RATES = (0.5, 1.0, 2.0, 4.0, 5.0, 10.0, 20.0, 30.0, 50.0, 100.0)

GCS_STREAMS = {  # message: period (s); None for "at the telemetry rate"
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


@cache
def onboard_streams() -> dict[str, float | None]:
    """PX4's API-link streams (message: period) as recorded, in the common dialect."""
    from ..conformance import load

    known = {cls.msgname for cls in dialect().mavlink_map.values()}
    out: dict[str, float | None] = {}
    for name, rate in load()["streams"].items():
        if name in known and hasattr(Streams, "_msg_" + name.lower()):
            nominal = min(NOMINAL_RATES, key=lambda r: abs(r - rate))
            out[name] = 1.0 / nominal
    # GLOBAL_POSITION_INT last (see GCS_STREAMS).
    gpi = out.pop("GLOBAL_POSITION_INT", None)
    out["GLOBAL_POSITION_INT"] = gpi
    return out


@cache
def _fields(name: str) -> list[tuple[str, int, bool]]:
    cls = dialect().mavlink_map[getattr(dialect(), "MAVLINK_MSG_ID_" + name)]
    # array_lengths follow the wire order; fieldnames and fieldtypes the message's.
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    return [
        (f, lengths[f], t == "char") for f, t in zip(cls.fieldnames, cls.fieldtypes, strict=True)
    ]


class Streams(State):
    """Scheduled telemetry (a part of ``Autopilot``)."""

    _streams: dict[str, list[float]]
    _stream_defaults: dict[str, float | None]
    _stream_list: list[tuple[str, list[float], Any]]
    _next_due: float
    _ping_seq: int

    def _init_streams(self, profile: dict[str, float | None], telemetry_rate: float) -> None:
        self._stream_defaults = profile
        rate = 1.0 / telemetry_rate
        self._streams = {
            name: [rate if per is None else max(per, self.period), 0.0]
            for name, per in profile.items()
        }
        self._next_due = 0.0
        self._ping_seq = 0
        self._stream_list = [
            (name, slot, getattr(self, "_msg_" + name.lower()))
            for name, slot in self._streams.items()
        ]

    def message(self, name: str, **fields: Any) -> Any:
        """A message of ``name`` from ``fields`` (the others zero)."""
        cls = getattr(self._d, "MAVLink_" + name.lower() + "_message")
        args = []
        for f, n, is_char in _fields(name):
            v = fields.get(f)
            if v is None:
                v = b"" if is_char else ([0] * n if n else 0)
            args.append(v)
        return cls(*args)

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
                    self._out.append(msg)  # pack_scalar kept its message in _out_msgs
                else:
                    self._send(msg)
            if slot[1] < next_due:
                next_due = slot[1]
        self._next_due = next_due
        dirty.clear()

    def set_interval(self, name: str, interval_us: float) -> bool:
        """SET_MESSAGE_INTERVAL for message ``name``; False if it cannot be streamed."""
        if not hasattr(self, "_msg_" + name.lower()):
            return False
        if name not in self._streams:
            slot = [math.inf, 0.0]
            self._streams[name] = slot
            self._stream_list.append((name, slot, getattr(self, "_msg_" + name.lower())))
        slot = self._streams[name]
        if interval_us == 0:
            per = self._stream_defaults.get(name, math.inf)
            slot[0] = per if per is not None else 1.0 / self.spec.telemetry_rate
        elif interval_us < 0:
            slot[0] = math.inf
        else:
            slot[0] = max(interval_us * 1e-6, self.period)
        slot[1] = self._now
        self._next_due = self._now
        return True

    def interval_us(self, name: str) -> int:
        """The current interval of ``name`` (-1: not streamed)."""
        slot = self._streams.get(name)
        if slot is None or slot[0] == math.inf:
            return -1
        return round(slot[0] * 1e6)

    # -- the messages -----------------------------------------------------------------------

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
            present, present, health, 250, 16200, -1, 100, 0, 0, 0, 0, 0, 0, 0, 0, 0
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

    def _msg_gps_raw_int(self) -> Any:
        est = self.est
        lat, lon, alt, eph, epv, vel, cog = est.gps_raw
        # The world's geoid is the ellipsoid: the ellipsoid height is the AMSL altitude.
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
            alt,
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
            keep=self._out_msgs,
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
            keep=self._out_msgs,
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
            keep=self._out_msgs,
        )

    def _msg_attitude_quaternion(self) -> Any:
        q, r = self.est.q, self.est.rates
        return self.message(
            "ATTITUDE_QUATERNION",
            time_boot_ms=round(self._now * 1000),
            q1=q[0],
            q2=q[1],
            q3=q[2],
            q4=q[3],
            rollspeed=r[0],
            pitchspeed=r[1],
            yawspeed=r[2],
        )

    def _msg_altitude(self) -> Any:
        est = self.est
        alt = est.origin_alt - est.pos[2]
        home_alt = self.home[5] if self.home is not None else est.origin_alt
        return self.message(
            "ALTITUDE",
            time_usec=round(self._now * 1e6),
            altitude_monotonic=alt,
            altitude_amsl=alt,
            altitude_local=-est.pos[2],
            altitude_relative=alt - home_alt,
            altitude_terrain=math.nan,
            bottom_clearance=math.nan,
        )

    def _msg_attitude_target(self) -> Any:
        return self.message(
            "ATTITUDE_TARGET", time_boot_ms=round(self._now * 1000), q=[1.0, 0.0, 0.0, 0.0]
        )

    def _msg_battery_status(self) -> Any:
        return self.message(
            "BATTERY_STATUS",
            voltages=[4200, 4200, 4200, 4200, 65535, 65535, 65535, 65535, 65535, 65535],
            current_battery=-1,
            current_consumed=-1,
            energy_consumed=-1,
            battery_remaining=100,
            battery_function=1,
            type=1,
        )

    def _msg_estimator_status(self) -> Any:
        ok = self.est.position_ok(self._now)
        return self.message(
            "ESTIMATOR_STATUS",
            time_usec=round(self._now * 1e6),
            flags=(1 | 2 | 4 | 8 | 16 | 32) if ok else (1 | 4),
        )

    def _msg_highres_imu(self) -> Any:
        est = self.est
        acc = est._acc_b
        r = est.rates
        return self.message(
            "HIGHRES_IMU",
            time_usec=round(self._now * 1e6),
            xacc=acc[0],
            yacc=acc[1],
            zacc=acc[2],
            xgyro=r[0],
            ygyro=r[1],
            zgyro=r[2],
            pressure_alt=est.origin_alt - est.pos[2],
            fields_updated=0x1FFF,
        )

    def _msg_odometry(self) -> Any:
        est = self.est
        pos, vel, r = est.pos, est.vel, est.rates
        return self.message(
            "ODOMETRY",
            time_usec=round(self._now * 1e6),
            frame_id=1,
            child_frame_id=12,
            x=pos[0],
            y=pos[1],
            z=pos[2],
            q=list(est.q),
            vx=vel[0],
            vy=vel[1],
            vz=vel[2],
            rollspeed=r[0],
            pitchspeed=r[1],
            yawspeed=r[2],
            pose_covariance=[math.nan] * 21,
            velocity_covariance=[math.nan] * 21,
            estimator_type=3,
        )

    def _msg_open_drone_id_location(self) -> Any:
        lat, lon, alt = self.est.global_position()
        return self.message(
            "OPEN_DRONE_ID_LOCATION",
            latitude=round(lat * 1e7),
            longitude=round(lon * 1e7),
            altitude_geodetic=alt,
            altitude_barometric=alt,
            height=-1000,
            id_or_mac=[0] * 20,
        )

    def _msg_open_drone_id_system(self) -> Any:
        return self.message("OPEN_DRONE_ID_SYSTEM", id_or_mac=[0] * 20)

    def _msg_ping(self) -> Any:
        self._ping_seq = (self._ping_seq + 1) & 0xFFFFFFFF
        return self.message("PING", time_usec=round(self._now * 1e6), seq=self._ping_seq)

    def _msg_position_target_local_ned(self) -> bytes:
        """What the position controller is asked for, beside what the vehicle does."""
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
            keep=self._out_msgs,
        )

    def _msg_scaled_pressure(self) -> Any:
        alt = self.est.origin_alt - self.est.pos[2]
        press = 1013.25 * (1.0 - 2.25577e-5 * alt) ** 5.25588
        return self.message(
            "SCALED_PRESSURE",
            time_boot_ms=round(self._now * 1000),
            press_abs=press,
            temperature=2000,
        )

    def _msg_servo_output_raw(self) -> Any:
        pwm = 1500 if self.armed else 900
        return self.message(
            "SERVO_OUTPUT_RAW",
            time_usec=round(self._now * 1e6) & 0xFFFFFFFF,
            servo1_raw=pwm,
            servo2_raw=pwm,
            servo3_raw=pwm,
            servo4_raw=pwm,
        )

    def _msg_system_time(self) -> Any:
        return self.message("SYSTEM_TIME", time_boot_ms=round(self._now * 1000))

    def _msg_timesync(self) -> Any:
        return self.message("TIMESYNC", tc1=0, ts1=round(self._now * 1e9))

    def _msg_vfr_hud(self) -> Any:
        est = self.est
        vel = est.vel
        return self.message(
            "VFR_HUD",
            groundspeed=math.hypot(vel[0], vel[1]),
            heading=round(math.degrees(est.euler()[2])) % 360,
            throttle=50 if self.armed and not self.landed else 0,
            alt=est.origin_alt - est.pos[2],
            climb=-vel[2],
        )

    def _msg_vibration(self) -> Any:
        return self.message("VIBRATION", time_usec=round(self._now * 1e6))

    def _msg_hil_state_quaternion(self) -> Any:
        """Ground truth, from the world's truth topic (the estimate until it has spoken)."""
        t = self.truth
        est = self.est
        if t is None or est.origin is None:
            lat, lon, alt = est.global_position()
            q, vel = est.q, est.vel
        else:
            lat, lon = t.lat, t.lon
            alt = est.origin_alt + t.alt
            q, vel = [t.qw, t.qx, t.qy, t.qz], [t.vn, t.ve, t.vd]
        return self.message(
            "HIL_STATE_QUATERNION",
            time_usec=round(self._now * 1e6),
            attitude_quaternion=list(q),
            lat=round(lat * 1e7),
            lon=round(lon * 1e7),
            alt=round(alt * 1000),
            vx=round(vel[0] * 100),
            vy=round(vel[1] * 100),
            vz=round(vel[2] * 100),
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
