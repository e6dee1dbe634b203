"""The MAVLink link of the autopilot: framing, dispatch, and the setpoint messages.

Incoming frames are decoded and dispatched by message name to ``_on_<name>`` handlers of
the autopilot's parts (``commands``, ``paramserver``, ``missions``, and the
setpoint streams here: MANUAL_CONTROL, SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT,
SET_ATTITUDE_TARGET, FOLLOW_TARGET). Malformed requests are logged and ignored.
"""

from __future__ import annotations

import logging
import math
from typing import Any

from ...mavlink.dialect import (
    FRAME_BODY_NED,
    FRAME_BODY_OFFSET_NED,
    FRAME_GLOBAL,
    FRAME_GLOBAL_INT,
    FRAME_LOCAL_OFFSET_NED,
    SEV_INFO,
    TARGET_IGNORE_POSITION,
    TARGET_IGNORE_VELOCITY,
    TARGET_IGNORE_YAW,
)
from .navigator import FOLLOW_MIN_COURSE_SPEED, FOLLOW_VELOCITY_TAU
from .state import Setpoint, State

__all__ = ["Server"]

log = logging.getLogger(__name__)

# POSITION_TARGET_TYPEMASK / ATTITUDE_TARGET_TYPEMASK bits.
IGNORE_ATTITUDE, IGNORE_THRUST = 128, 64


class Server(State):
    """The link itself (a part of ``Autopilot``)."""

    def _send(self, msg: Any) -> None:
        mav = self.mav
        self._out.append(bytes(msg.pack(mav)))
        self._out_msgs.append(None)  # decoded by the receiver (rare, low-rate messages)
        mav.seq = (mav.seq + 1) & 0xFF

    def _text(self, text: str, severity: int = SEV_INFO) -> None:
        self._send(self._d.MAVLink_statustext_message(severity, text.encode()[:50], 0, 0))

    def _handle(self, m: Any) -> None:
        name = m.get_type()
        target = getattr(m, "target_system", None)
        if target not in (None, 0, self.system_id):
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

    def _on_manual_control(self, m: Any) -> None:
        # x, y, r in [-1000, 1000], z (throttle) in [0, 1000].
        self._manual = (
            _unit(m.x * 1e-3),
            _unit(m.y * 1e-3),
            min(max(m.z * 1e-3, 0.0), 1.0),
            _unit(m.r * 1e-3),
            self._now,
        )

    def _on_set_position_target_local_ned(self, m: Any) -> None:
        mask = m.type_mask
        pos = None if mask & TARGET_IGNORE_POSITION else (m.x, m.y, m.z)
        vel = None if mask & TARGET_IGNORE_VELOCITY else (m.vx, m.vy, m.vz)
        if m.coordinate_frame in (FRAME_BODY_NED, FRAME_BODY_OFFSET_NED):
            yaw = self.est.euler()[2]
            c, s = math.cos(yaw), math.sin(yaw)
            if vel is not None:
                vel = (vel[0] * c - vel[1] * s, vel[0] * s + vel[1] * c, vel[2])
            if pos is not None and m.coordinate_frame == FRAME_BODY_OFFSET_NED:
                p = self.est.pos
                pos = (
                    p[0] + pos[0] * c - pos[1] * s,
                    p[1] + pos[0] * s + pos[1] * c,
                    p[2] + pos[2],
                )
        elif pos is not None and m.coordinate_frame == FRAME_LOCAL_OFFSET_NED:
            p = self.est.pos
            pos = (p[0] + pos[0], p[1] + pos[1], p[2] + pos[2])
        self._setpoint_in(pos, vel, None if mask & TARGET_IGNORE_YAW else m.yaw)

    def _on_set_position_target_global_int(self, m: Any) -> None:
        mask = m.type_mask
        pos = None
        origin = self.est.origin
        if not mask & TARGET_IGNORE_POSITION and origin is not None:
            n, e = origin.project(m.lat_int * 1e-7, m.lon_int * 1e-7)
            if m.coordinate_frame in (FRAME_GLOBAL, FRAME_GLOBAL_INT):
                d = self.est.origin_alt - m.alt
            else:
                d = (self.home[2] if self.home is not None else 0.0) - m.alt
            pos = (n, e, d)
        vel = None if mask & TARGET_IGNORE_VELOCITY else (m.vx, m.vy, m.vz)
        self._setpoint_in(pos, vel, None if mask & TARGET_IGNORE_YAW else m.yaw)

    def _setpoint_in(self, pos: Any, vel: Any, yaw: float | None) -> None:
        if pos is not None and not all(math.isfinite(v) for v in pos):
            pos = None
        if vel is not None and not all(math.isfinite(v) for v in vel):
            vel = None
        if yaw is not None and not math.isfinite(yaw):
            yaw = None
        self._offboard = Setpoint(self._now, pos=pos, vel=vel, yaw=yaw)

    def _on_set_attitude_target(self, m: Any) -> None:
        mask = m.type_mask
        q = None if mask & IGNORE_ATTITUDE else tuple(float(v) for v in m.q)
        thrust = None if mask & IGNORE_THRUST else float(m.thrust)
        if q is not None and not all(math.isfinite(v) for v in q):
            return
        self._offboard = Setpoint(self._now, attitude=q, thrust=thrust)  # type: ignore[arg-type]

    def _on_follow_target(self, m: Any) -> None:
        lat, lon = m.lat * 1e-7, m.lon * 1e-7
        if (m.lat == 0 and m.lon == 0) or abs(lat) > 90 or abs(lon) > 180:
            return  # velocity alone: nothing to follow (PX4 needs a position)
        vel = [float(v) for v in m.vel]
        last = self._follow
        origin = self.est.origin
        if not all(math.isfinite(v) for v in vel):
            # Position only: estimate the target's velocity from its track, low-passed as
            # PX4's target estimator does, so that one noisy fix does not swing the course.
            vel = [0.0, 0.0, 0.0]
            if last is not None and origin is not None and self._now > last[6]:
                dt = self._now - last[6]
                n0, e0 = origin.project(last[0], last[1])
                n1, e1 = origin.project(lat, lon)
                k = dt / (FOLLOW_VELOCITY_TAU + dt)
                vel[0] = last[3] + k * ((n1 - n0) / dt - last[3])
                vel[1] = last[4] + k * ((e1 - e0) / dt - last[4])
        if math.hypot(vel[0], vel[1]) > FOLLOW_MIN_COURSE_SPEED:
            self._follow_course = math.atan2(vel[1], vel[0])
        self._follow = (lat, lon, float(m.alt), vel[0], vel[1], vel[2], self._now)


def _unit(x: float) -> float:
    return min(max(x, -1.0), 1.0)
