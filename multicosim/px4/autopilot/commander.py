"""The commander: arming checks, flight modes, failsafes, the land detector, auto-disarm."""

from __future__ import annotations

import math

from ...core.geo import GRAVITY
from ...mavlink.dialect import (
    CMD_LAND,
    CMD_RTL,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_PAUSED,
    SEV_CRITICAL,
    SEV_NOTICE,
    SEV_WARNING,
)
from ..modes import Mode
from .state import State

__all__ = ["Commander"]

# Modes that need a valid position estimate (PX4's mode requirements).
POSITION_MODES = (
    Mode.MISSION,
    Mode.RTL,
    Mode.TAKEOFF,
    Mode.POSCTL,
    Mode.FOLLOW_TARGET,
)
MANUAL_MODES = (Mode.MANUAL, Mode.ALTCTL, Mode.POSCTL, Mode.ACRO, Mode.STABILIZED)
# COM_OBL_RC_ACT: the mode to fall back to when offboard is lost (PX4 v1.15's
# offboard_loss_failsafe_mode; 6 Terminate and 7 Disarm are not simulated: they land).
OFFBOARD_LOSS_MODES = {
    0: Mode.POSCTL,
    1: Mode.ALTCTL,
    2: Mode.STABILIZED,
    3: Mode.RTL,
    4: Mode.LAND,
    5: Mode.LOITER,
}


class Commander(State):
    """Arming, modes and failsafes (a part of ``Autopilot``)."""

    def arm_check(self) -> str | None:
        """Why arming would be refused now, or None (PX4's preflight checks, simplified)."""
        now, est = self._now, self.est
        if now - est.last_imu > 0.5 or not est.attitude_ok:
            return "Preflight Fail: accel/gyro not ready"
        if now - est.last_mag > 1.0 and not self._failed("mag"):
            return "Preflight Fail: no magnetometer"
        if now - est.last_baro > 1.0 and not self._failed("baro"):
            return "Preflight Fail: no barometer"
        # PX4's failure detector (FD_FAIL_R / FD_FAIL_P): a vehicle lying tipped over, by the
        # wind say, is refused arming (PX4 also waits FD_FAIL_*_TTRI, 0.3 s: one on the ground
        # stays tipped).
        roll, pitch, _ = est.euler()
        if abs(math.degrees(roll)) > self.params["FD_FAIL_R"]:
            return "Preflight Fail: Attitude failure (roll)"
        if abs(math.degrees(pitch)) > self.params["FD_FAIL_P"]:
            return "Preflight Fail: Attitude failure (pitch)"
        if self.mode in (*POSITION_MODES, Mode.LOITER, Mode.OFFBOARD, Mode.LAND, Mode.RTL):
            if not est.gps_ok(now):
                return "Preflight Fail: GPS fix too low"
            if not est.position_ok(now):
                return "Preflight Fail: position estimate not valid"
        if self.mode == Mode.MISSION and not self.mission:
            return "Arming denied: no mission"
        return None

    def _failed(self, sensor: str) -> bool:
        return sensor in self.failures

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
        self._hold = (self.est.pos[0], self.est.pos[1], self.est.pos[2])
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
        """Switch flight mode; returns why it was refused, or None.

        As PX4 does, OFFBOARD is entered only while setpoints arrive; otherwise the request
        is acknowledged and the mode stays as it was.
        """
        # Disarmed, any mode may be selected (PX4 checks its requirements when arming).
        if self.armed and mode in POSITION_MODES and not self.est.position_ok(self._now):
            return "no valid position"
        if self.armed and mode == Mode.RTL and self.home is None:
            return "no home position"
        if mode == Mode.OFFBOARD and not self._offboard_fresh():
            return None
        self._offboard_lost = False  # a mode the user chose ends the offboard fallback
        if mode == self.mode and mode != Mode.MISSION:
            return None
        self._enter(mode)
        return None

    def _enter(self, mode: Mode) -> None:
        """Switch to ``mode`` (the user's choice or a failsafe's): reset what it starts from."""
        self.mode = mode
        self._phase = ""
        self._follow_adjust = [0.0, 0.0, 0.0]
        self._follow_angle = None
        self._target = None
        if not self.landed:
            self._hold = (self.est.pos[0], self.est.pos[1], self.est.pos[2])
        if mode == Mode.MISSION and self.mission:
            if self.seq >= len(self.mission):
                self.seq = 0
                self._jumps = {}
            self.mission_state = MISSION_STATE_ACTIVE
            self._start_mission_item()
            self._dirty.add("MISSION_CURRENT")
        elif self.mission_state == MISSION_STATE_ACTIVE:
            self.mission_state = MISSION_STATE_PAUSED
            self._dirty.add("MISSION_CURRENT")
        self._dirty.add("HEARTBEAT")

    def _offboard_fresh(self) -> bool:
        sp = self._offboard
        return sp is not None and self._now - sp.time <= self.params["COM_OF_LOSS_T"]

    def _commander(self) -> None:
        now, est, p = self._now, self.est, self.params
        if self.home is None and est.position_ok(now):
            self._set_home()
        if not self.armed:
            return
        self._position_failsafe()
        self._offboard_failsafe()
        # Land detector: asked to descend, but not moving down (the ground holds it).
        if self.landed:
            if est.pos[2] < self._ground_d - 0.4:
                self.landed = False
                self._flew = True
                self._touch_since = None
                self._dirty.add("EXTENDED_SYS_STATE")
        elif self._touching():
            if self._touch_since is None:
                self._touch_since = now
            elif now - self._touch_since > (1.0 if self.velocity_vehicle else 0.7):
                self._landing_detected()
        else:
            self._touch_since = None
        if self.landed:
            delay = p["COM_DISARM_LAND"]
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
            prflt = p["COM_DISARM_PRFLT"]
            if (
                not self._flew
                and prflt > 0
                and now - self._armed_at > prflt
                and (self.mode in (Mode.LOITER, *MANUAL_MODES))
            ):
                self._text("Disarmed: no takeoff", SEV_NOTICE)
                self.disarm()

    def _offboard_failsafe(self) -> None:
        """Offboard lost after COM_OF_LOSS_T: COM_OBL_RC_ACT's mode until setpoints return.

        As PX4 v1.15's failsafe framework (commander/failsafe: a mode fallback clears with
        its condition): the user's mode stays offboard, so offboard resumes when setpoints
        come again. Position mode without sticks holds where it is; a mode that needs a
        position falls back to Altitude mode without one (FallbackPosCtrl's fall-through).
        """
        fresh = self._offboard_fresh()
        if self.mode == Mode.OFFBOARD and not fresh:
            fallback = OFFBOARD_LOSS_MODES.get(int(self.params["COM_OBL_RC_ACT"]), Mode.LAND)
            needs_position = (*POSITION_MODES, Mode.LOITER, Mode.LAND)
            if fallback in needs_position and not self.est.position_ok(self._now):
                fallback = Mode.ALTCTL
            self._text("Failsafe activated: no offboard", SEV_WARNING)
            self._enter(fallback)
            self._offboard_lost = True
        elif self._offboard_lost and fresh:
            self._text("Failsafe deactivated")
            self._enter(Mode.OFFBOARD)
            self._offboard_lost = False

    def _touching(self) -> bool:
        """Asked to descend but not moving down: the ground holds the vehicle.

        On the quadrotor, as PX4's land detector, also low thrust: the velocity loop has
        wound the thrust well below hover because the ground carries the weight.
        """
        if self._vz_sp <= 0.2:
            return False
        vz = abs(self.est.vel[2])
        if self.velocity_vehicle:
            return vz < 0.15
        ctl = self.ctl
        return vz < 0.25 and ctl.thrust < 0.8 * ctl.v.mass * GRAVITY

    def _landing_detected(self) -> None:
        est = self.est
        self.landed = True
        self._landed_at = self._now
        self._ground_d = est.pos[2]
        self._hold = (est.pos[0], est.pos[1], est.pos[2])
        self._dirty.add("EXTENDED_SYS_STATE")
        self._text("Landing detected")
        if (
            self.mode == Mode.MISSION
            and self.seq < len(self.mission)
            and (self.mission[self.seq].command in (CMD_LAND, CMD_RTL))
        ):
            self._item_reached()

    def _position_failsafe(self) -> None:
        """Without GPS, PX4 dead-reckons EKF2_NOAID_TOUT, then fails over.

        Its estimator then marks the position invalid and the commander drops it at once
        (COM_POS_FS_DELAY only ages out a position that stops arriving at all).
        """
        if self.landed or self.failsafe is not None or self.est.position_ok(self._now):
            return
        if self.mode in (Mode.MANUAL, Mode.ALTCTL, Mode.ACRO, Mode.STABILIZED):
            return  # these modes need no position
        self.failsafe = "GPS lost"
        self._text("Failsafe activated: GPS lost", SEV_CRITICAL)
        self.mode = Mode.LAND
        self._phase = ""
        self._dirty.add("HEARTBEAT")
