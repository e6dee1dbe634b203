"""COMMAND_LONG / COMMAND_INT, answered with COMMAND_ACK as PX4 v1.15.4 answers them.

The answers in each state are the ones recorded from real PX4 (``conformance``):
commands PX4 does not implement are UNSUPPORTED, REQUEST_MESSAGE of an unknown message is
DENIED, DO_SET_MODE is accepted for every PX4 mode while disarmed (OFFBOARD is entered only
while setpoints arrive), MISSION_START without a mission is DENIED.
"""

from __future__ import annotations

import math
from typing import Any

from ...mavlink.dialect import (
    CMD_ARM_DISARM,
    CMD_DO_CHANGE_SPEED,
    CMD_DO_REPOSITION,
    CMD_DO_SET_HOME,
    CMD_DO_SET_MODE,
    CMD_GET_HOME,
    CMD_GET_MSG_INTERVAL,
    CMD_INJECT_FAILURE,
    CMD_LAND,
    CMD_MISSION_START,
    CMD_REQUEST_CAPABILITIES,
    CMD_REQUEST_MESSAGE,
    CMD_RTL,
    CMD_SET_MSG_INTERVAL,
    CMD_TAKEOFF,
    FORCE_MAGIC,
    FRAME_GLOBAL,
    FRAME_GLOBAL_INT,
    MODE_FLAG_CUSTOM,
    MSG_PROTOCOL_VERSION,
    RESULT_ACCEPTED,
    RESULT_DENIED,
    RESULT_TEMP_REJECTED,
    RESULT_UNSUPPORTED,
    SEV_WARNING,
)
from ..modes import Mode
from .state import State

__all__ = ["Commands"]

REPOSITION_CHANGE_MODE = 1  # MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, DO_REPOSITION's param 2

# Messages REQUEST_MESSAGE is answered for beyond the streams (PX4 accepts these; the ones
# our dialect cannot encode are acknowledged only).
ONE_SHOT = {"AUTOPILOT_VERSION", "PROTOCOL_VERSION", "GPS_GLOBAL_ORIGIN", "FLIGHT_INFORMATION"}


class Commands(State):
    """The command protocol (a part of ``Autopilot``)."""

    def _ack(self, command: int, result: int) -> None:
        src_sys, src_comp = self._gcs
        self._send(self._d.MAVLink_command_ack_message(command, result, 0, 0, src_sys, src_comp))
        for msg in self._after_ack:
            self._send(msg)
        self._after_ack.clear()

    def _on_command_long(self, m: Any) -> None:
        p = (m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7)
        self._ack(m.command, self._command(m.command, p, FRAME_GLOBAL))

    def _on_command_int(self, m: Any) -> None:
        p = (m.param1, m.param2, m.param3, m.param4, m.x * 1e-7, m.y * 1e-7, m.z)
        self._ack(m.command, self._command(m.command, p, m.frame))

    def _command(self, cmd: int, p: tuple[float, ...], frame: int) -> int:
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
            if not self.mission:
                return RESULT_DENIED
            if 0 <= _int(p[0]) < len(self.mission):
                self.seq = _int(p[0])
            return self._mode_result(Mode.MISSION)
        if cmd == CMD_TAKEOFF:
            alt = p[6]
            if math.isfinite(alt) and self.home is not None:
                self.params["MIS_TAKEOFF_ALT"] = max(1.0, alt - self.home[5])
            return self._mode_result(Mode.TAKEOFF)
        if cmd == CMD_LAND:
            return self._mode_result(Mode.LAND)
        if cmd == CMD_RTL:
            return self._mode_result(Mode.RTL)
        if cmd == CMD_DO_REPOSITION:
            return self._reposition(p, frame)
        if cmd == CMD_DO_CHANGE_SPEED:
            if math.isfinite(p[1]) and p[1] > 0:
                self._cruise = p[1]
            return RESULT_ACCEPTED
        if cmd == CMD_DO_SET_HOME:
            return self._set_home_to(p, frame)
        if cmd == CMD_GET_HOME:
            if self.home is None:
                return RESULT_TEMP_REJECTED
            self._dirty.add("HOME_POSITION")
            return RESULT_ACCEPTED
        if cmd == CMD_INJECT_FAILURE:
            return self.inject_failure(_int(p[0]), _int(p[1]), _int(p[2]))
        if cmd in (CMD_REQUEST_MESSAGE, CMD_REQUEST_CAPABILITIES):
            msgid = 148 if cmd == CMD_REQUEST_CAPABILITIES else _int(p[0])
            return self._request_message(msgid)
        if cmd == CMD_SET_MSG_INTERVAL:
            cls = self._d.mavlink_map.get(_int(p[0]))
            interval = p[1] if math.isfinite(p[1]) else 0.0
            if cls is None or not self.set_interval(cls.msgname, interval):
                return RESULT_UNSUPPORTED
            return RESULT_ACCEPTED
        if cmd == CMD_GET_MSG_INTERVAL:
            cls = self._d.mavlink_map.get(_int(p[0]))
            if cls is None:
                return RESULT_DENIED
            self._after_ack.append(
                self._d.MAVLink_message_interval_message(cls.id, self.interval_us(cls.msgname))
            )
            return RESULT_ACCEPTED
        return RESULT_UNSUPPORTED

    def _mode_result(self, mode: Mode) -> int:
        reason = self.set_mode(mode)
        if reason is None:
            return RESULT_ACCEPTED
        self._text(f"Mode {mode.label} denied: {reason}", SEV_WARNING)
        return RESULT_DENIED

    def _local(self, p: tuple[float, ...], frame: int) -> tuple[float, float, float | None] | None:
        """Local NED of a command's lat/lon/alt (params 5-7), None if not given."""
        origin = self.est.origin
        lat, lon, alt = p[4], p[5], p[6]
        if origin is None or not (math.isfinite(lat) and math.isfinite(lon)):
            return None
        if lat == 0 and lon == 0:
            return None
        n, e = origin.project(lat, lon)
        if not math.isfinite(alt):
            return n, e, None
        if frame in (FRAME_GLOBAL, FRAME_GLOBAL_INT):
            return n, e, self.est.origin_alt - alt
        home_d = self.home[2] if self.home is not None else 0.0
        return n, e, home_d - alt

    def _reposition(self, p: tuple[float, ...], frame: int) -> int:
        """DO_REPOSITION as PX4 v1.15 does it: the commander answers, the navigator flies.

        The commander wants the change-mode flag (param 2 is 1): without it the answer is
        UNSUPPORTED, with it the mode becomes Hold. The navigator takes the position whatever
        the answer, armed and in the air, and Hold flies there (Commander::handle_command,
        Navigator::run).
        """
        if _int(p[1]) != REPOSITION_CHANGE_MODE:
            result = RESULT_UNSUPPORTED
        elif self.set_mode(Mode.LOITER) is None:
            result = RESULT_ACCEPTED
        else:
            result = RESULT_TEMP_REJECTED
        if not self.armed or self.landed or self.mode != Mode.LOITER:
            return result
        target = self._local(p, frame)
        pos = self.est.pos
        if target is None:
            alt = p[6]
            if not math.isfinite(alt):
                return result
            target = (pos[0], pos[1], self.est.origin_alt - alt)
        n, e, d = target
        speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else None
        self.reposition(n, e, d, speed)
        return result

    def _set_home_to(self, p: tuple[float, ...], frame: int) -> int:
        if p[0] > 0.5:
            self._set_home()
            return RESULT_ACCEPTED
        origin = self.est.origin
        if origin is None or not all(math.isfinite(v) for v in p[4:7]):
            return RESULT_DENIED
        lat, lon, alt = p[4], p[5], p[6]
        n, e = origin.project(lat, lon)
        self.home = (n, e, self.est.origin_alt - alt, lat, lon, alt)
        self._dirty.add("HOME_POSITION")
        return RESULT_ACCEPTED

    def _request_message(self, msgid: int) -> int:
        if msgid == MSG_PROTOCOL_VERSION:
            return RESULT_ACCEPTED  # not in our dialect: acknowledged, as PX4 does
        cls = self._d.mavlink_map.get(msgid)
        if cls is None:
            return RESULT_DENIED
        name = cls.msgname
        if name == "AUTOPILOT_VERSION":
            self._after_ack.append(self._autopilot_version())
            return RESULT_ACCEPTED
        if name == "GPS_GLOBAL_ORIGIN":
            est = self.est
            if est.origin is not None:
                self._after_ack.append(
                    self._d.MAVLink_gps_global_origin_message(
                        round(est.origin.lat * 1e7),
                        round(est.origin.lon * 1e7),
                        round(est.origin_alt * 1000),
                        round(self._now * 1e6),
                    )
                )
            return RESULT_ACCEPTED
        if name == "FLIGHT_INFORMATION":
            self._after_ack.append(
                self.message("FLIGHT_INFORMATION", time_boot_ms=round(self._now * 1000))
            )
            return RESULT_ACCEPTED
        if name == "HOME_POSITION" and self.home is None:
            return RESULT_TEMP_REJECTED
        if hasattr(self, "_msg_" + name.lower()):
            self._after_ack.append(getattr(self, "_msg_" + name.lower())())
            return RESULT_ACCEPTED
        return RESULT_DENIED


def _int(x: float) -> int:
    """``x`` rounded, with NaN and infinities ("unset" in MAVLink) as 0."""
    return round(x) if math.isfinite(x) else 0
