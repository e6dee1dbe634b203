"""The navigator: what the vehicle should do now, per flight mode, down to motor outputs.

Takeoff, mission items (acceptance radii, hold and loiter times, DO_CHANGE_SPEED, DO_JUMP;
commands with nothing to act on here, such as camera and gimbal ones, are noted), land,
return to launch (to the closest of home and the rally points), hold and reposition,
follow target, offboard setpoints (position, velocity, attitude) and the manual modes
(POSCTL holds position when the sticks are centred, ALTCTL and the others only height).
The controller (``control``) turns the result into motor outputs.
"""

from __future__ import annotations

import math

from ...mavlink.dialect import (
    CMD_DELAY,
    CMD_DO_CHANGE_SPEED,
    CMD_DO_JUMP,
    CMD_DO_SET_HOME,
    CMD_LAND,
    CMD_LOITER_TIME,
    CMD_LOITER_UNLIM,
    CMD_RTL,
    CMD_TAKEOFF,
    CMD_WAYPOINT,
    FRAME_GLOBAL,
    FRAME_GLOBAL_INT,
    MISSION_STATE_COMPLETE,
    MODE_FLAG_ARMED,
    NAV_COMMANDS,
    SEV_NOTICE,
)
from ...mavlink.hil import ACTUATOR_FLAG_VELOCITY, HilActuatorControls
from ...mavlink.plan import WAYPOINT_COMMANDS, command_name
from ..modes import Mode
from .control import position_control
from .state import Item, State, Vec3

__all__ = ["Navigator"]

_ZEROS12 = [0.0] * 12
MANUAL_DEADZONE = 0.05
MANUAL_YAW_RATE = math.radians(150.0)  # MPC_MAN_Y_MAX
FOLLOW_HEIGHT_RATE, FOLLOW_DISTANCE_RATE, FOLLOW_ANGLE_RATE = 1.5, 2.0, 1.5  # per full stick
FOLLOW_VELOCITY_TAU = 1.5  # s, low pass on the target's velocity estimated from its track
FOLLOW_MIN_COURSE_SPEED = 0.1  # m/s, below which the target's course is kept

# (position setpoint, vertical speed override, idle, horizontal velocity override)
Target = tuple[Vec3, float | None, bool, tuple[float, float] | None]


class Navigator(State):
    """Setpoints per mode and the control output (a part of ``Autopilot``)."""

    def _home_d(self) -> float:
        return self.home[2] if self.home is not None else self._ground_d

    def _item_target(self, item: Item) -> Vec3:
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
        """Make the current item a navigation item: do DO_ items on the way (PX4's order)."""
        self._phase = ""
        self._target = None
        self._reached_at = None
        for _ in range(4 * len(self.mission) + 1):  # DO_JUMP loops are bounded by repeats
            if self.seq >= len(self.mission):
                return
            item = self.mission[self.seq]
            if item.command == CMD_DO_CHANGE_SPEED:
                if item.param2 > 0:
                    self._cruise = item.param2
                self._item_reached()
            elif item.command == CMD_DO_JUMP:
                done = self._jumps.get(item.seq, 0)
                target = int(item.param1)
                if done < int(item.param2) and 0 <= target < len(self.mission):
                    self._jumps[item.seq] = done + 1
                    self.seq = target
                    self._dirty.add("MISSION_CURRENT")
                else:
                    self.seq += 1
            elif item.command == CMD_DO_SET_HOME:
                # Here (param 1 = 1) or at the item's position (AMSL), as the command does.
                where = (item.x * 1e-7, item.y * 1e-7, item.z)
                self._set_home_to((item.param1, 0.0, 0.0, 0.0, *where), item.frame)
                self._item_reached()
            elif item.command not in NAV_COMMANDS:
                # Camera, gimbal, region of interest: nothing in our world to act on. Said,
                # so that the flight's messages record it, and passed, as PX4 passes them.
                name = command_name(item.command).removeprefix("MAV_CMD_")
                self._text(f"Item {item.seq}: {name} has no effect", SEV_NOTICE)
                self._item_reached()
            else:
                return

    def _item_reached(self) -> None:
        self._send(self._d.MAVLink_mission_item_reached_message(self.seq))
        self.seq += 1
        self._phase = ""
        self._target = None
        self._reached_at = None
        self._dirty.add("MISSION_CURRENT")
        if self.seq < len(self.mission) and self.mission[self.seq].command not in NAV_COMMANDS:
            self._start_mission_item()
        if self.seq >= len(self.mission):
            self.mission_state = MISSION_STATE_COMPLETE
            self._text("Mission finished")

    def _blind(self) -> bool:
        """No position to fly by: the failsafe took over, or the estimate has none."""
        return self.failsafe is not None or not self.est.position_ok(self._now)

    def _land_speed(self) -> float:
        if self._blind():
            # Blind, PX4 descends (its Descend mode) at the landing speed all the way down.
            return self.params["MPC_LAND_SPEED"]
        height = self._home_d() - self.est.pos[2]
        if height > self.params["MPC_LAND_ALT2"]:
            return self.params["MPC_Z_V_AUTO_DN"]
        return self.params["MPC_LAND_SPEED"]

    def _setpoint(self) -> Target:
        """What to fly now for the current mode."""
        est, p = self.est, self.params
        pos = est.pos
        mode = self.mode
        if self.landed and not self._wants_takeoff():
            return (pos[0], pos[1], pos[2]), None, True, None
        if mode == Mode.LOITER:
            return self._hold, None, False, None
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
            return t, None, False, None
        if mode == Mode.LAND:
            return self._hold, self._land_speed(), False, None
        if mode == Mode.RTL:
            return self._rtl()
        if mode == Mode.MISSION:
            return self._mission()
        if mode == Mode.OFFBOARD:
            return self._offboard_setpoint()
        if mode == Mode.FOLLOW_TARGET:
            return self._follow_setpoint()
        return self._manual_setpoint()

    def _wants_takeoff(self) -> bool:
        if not self.armed:
            return False
        mode = self.mode
        if mode == Mode.TAKEOFF:
            return True
        if mode == Mode.MISSION:
            return self.seq < len(self.mission) and (
                self.mission[self.seq].command not in (CMD_LAND, CMD_RTL)
            )
        if mode == Mode.OFFBOARD:
            sp = self._offboard
            if sp is None:
                return False
            if sp.thrust is not None:
                return sp.thrust > self.params["MPC_THR_HOVER"]
            if sp.pos is not None:
                return sp.pos[2] < self._ground_d - 0.3
            return sp.vel is not None and sp.vel[2] < -0.2
        if mode in (Mode.MANUAL, Mode.ALTCTL, Mode.POSCTL, Mode.ACRO, Mode.STABILIZED):
            m = self._manual
            return m is not None and m[2] > 0.5 + 2 * MANUAL_DEADZONE
        return False

    # -- return -----------------------------------------------------------------------------

    def _return_point(self) -> Vec3:
        """Where to return: home, or a rally point closer than home (PX4's RTL_TYPE 0/3)."""
        pos = self.est.pos
        home = self.home or (pos[0], pos[1], pos[2], 0.0, 0.0, 0.0)
        best = (home[0], home[1], home[2])
        origin = self.est.origin
        if origin is None:
            return best
        dist = math.hypot(pos[0] - best[0], pos[1] - best[1])
        for item in self.rally:
            n, e = origin.project(item.x * 1e-7, item.y * 1e-7)
            d = math.hypot(pos[0] - n, pos[1] - e)
            if d < dist:
                best, dist = (n, e, home[2]), d
        return best

    def _rtl(self) -> Target:
        est, p = self.est, self.params
        pos = est.pos
        if not self._phase:
            dest = self._return_point()
            far = math.hypot(pos[0] - dest[0], pos[1] - dest[1]) > p["NAV_ACC_RAD"]
            alt = max(p["RTL_RETURN_ALT"], dest[2] - pos[2]) if far else dest[2] - pos[2]
            self._target = (pos[0], pos[1], dest[2] - alt)
            self._hold = dest
            self._phase = "climb"
            self._text("RTL: climbing" if far else "RTL: landing")
        t = self._target
        assert t is not None
        if self._phase == "climb":
            if abs(pos[2] - t[2]) < p["NAV_MC_ALT_RAD"]:
                self._phase = "return"
                self._target = (self._hold[0], self._hold[1], t[2])
            return t, None, False, None
        if self._phase == "return":
            if math.hypot(pos[0] - t[0], pos[1] - t[1]) < p["NAV_ACC_RAD"]:
                self._phase = "descend"
                descend = self._hold[2] - p["RTL_DESCEND_ALT"]
                self._target = (t[0], t[1], max(t[2], descend))
                self._reached_at = None
                self._text("RTL: landing at home")
            return t, None, False, None
        if self._phase == "descend":
            if abs(pos[2] - t[2]) < p["NAV_MC_ALT_RAD"]:
                if self._reached_at is None:
                    self._reached_at = self._now
                if self._now - self._reached_at >= max(p["RTL_LAND_DELAY"], 0.0):
                    self._phase = "land"
                    self._hold = t
            return t, None, False, None
        return self._hold, self._land_speed(), False, None

    # -- mission ----------------------------------------------------------------------------

    def _mission(self) -> Target:
        est, p = self.est, self.params
        pos = est.pos
        if self.seq >= len(self.mission):
            if self._phase != "done":
                self._phase = "done"
                self._hold = (pos[0], pos[1], pos[2])
            return self._hold, None, False, None
        item = self.mission[self.seq]
        cmd = item.command
        if cmd == CMD_DO_JUMP:
            # Made current by MISSION_SET_CURRENT (see _on_mission_set_current): PX4 v1.15
            # waits on it with an idle setpoint; the vehicle stays where it is.
            return self._hold, None, False, None
        if cmd == CMD_DELAY:
            # Held for param 1 seconds at the last item's position, flown back to if it
            # overshot it, as real PX4 does (a time of day in params 2-4 it does not use).
            if self._reached_at is None:
                self._reached_at = self._now
            if self._now - self._reached_at >= max(item.param1, 0.0):
                self._item_reached()
            return self._hold, None, False, None
        if cmd == CMD_RTL:
            # PX4 v1.15 reports the item reached and the mission finished (its current item
            # stays), and hands the return over to its Return mode: climb, straight home
            # from where the vehicle is (not back along the last leg), land.
            # (Said once: while Return is refused, no position, the item is flown here.)
            if self.set_mode(Mode.RTL) is None and self.mode == Mode.RTL:
                self._send(self._d.MAVLink_mission_item_reached_message(self.seq))
                self.mission_state = MISSION_STATE_COMPLETE
                self._dirty.add("HEARTBEAT")
            return self._rtl()
        if self._target is None:
            self._target = self._item_target(item)
            if cmd == CMD_TAKEOFF:
                self._target = (pos[0], pos[1], self._target[2])
            # The leg starts where the last one ended (the item reached, or where the vehicle
            # was told to hold): PX4 flies the line between the two.
            self._leg_origin = (self._hold[0], self._hold[1])
            self._leg_speed = math.inf
        t = self._target
        if self.landed and self._phase == "":
            # On the ground with a mission to fly: take off first (PX4 does the same when
            # the mission does not begin with a takeoff item).
            alt = max(p["MIS_TAKEOFF_ALT"], self._home_d() - t[2], 1.0)
            self._hold = (pos[0], pos[1], self._home_d() - alt)
            self._phase = "takeoff"
        if self._phase == "takeoff":
            if abs(pos[2] - self._hold[2]) >= p["NAV_MC_ALT_RAD"]:
                return self._hold, None, False, None
            self._phase = "go"
            if cmd == CMD_TAKEOFF:
                # PX4 climbs where the vehicle stands, then flies at that height to the
                # takeoff item's own position, if it has one, before the next item.
                n, e, _ = self._item_target(item)
                if math.hypot(n - pos[0], e - pos[1]) < p["NAV_ACC_RAD"]:
                    self._item_reached()
                    return self._hold, None, False, None
                self._target = t = (n, e, self._hold[2])
                self._leg_origin = (pos[0], pos[1])
        if cmd == CMD_LAND:
            if self._phase in ("", "go"):
                self._phase = "approach"
                self._target = (t[0], t[1], pos[2])
                t = self._target
            if self._phase == "approach":
                if math.hypot(pos[0] - t[0], pos[1] - t[1]) < p["NAV_ACC_RAD"]:
                    self._phase = "descend"
                    self._hold = t
                return t, None, False, None
            if self.landed:
                self._item_reached()
            return self._hold, self._land_speed(), False, None
        # Waypoint (or takeoff when already airborne, or unlimited loiter).
        acc = item.param2 if cmd == CMD_WAYPOINT and item.param2 > 0 else p["NAV_ACC_RAD"]
        hdist = math.hypot(pos[0] - t[0], pos[1] - t[1])
        if cmd != CMD_LOITER_UNLIM and hdist < acc and abs(pos[2] - t[2]) < p["NAV_MC_ALT_RAD"]:
            hold_time = item.param1 if cmd in (CMD_WAYPOINT, CMD_LOITER_TIME) else 0.0
            # (LOITER_TO_ALT: a multicopter reaches its altitude there and goes on.)
            if self._reached_at is None:
                self._reached_at = self._now
            if self._now - self._reached_at >= hold_time:
                self._hold = t
                self._item_reached()
                return t, None, False, None
        if hdist > 2.0:
            self._yaw_sp = math.atan2(t[1] - pos[1], t[0] - pos[0])
        self._leg_speed = self._approach_speed(t, hdist, acc, item)
        return t, None, False, None

    def _approach_speed(self, t: Vec3, dist: float, acc: float, item: Item) -> float:
        """The fastest the vehicle may go ``dist`` m before waypoint ``t`` so as to make the
        turn to the next one within ``acc`` m (PX4's FlightTaskAuto: the speed a turn by
        ``alpha`` allows, sqrt(a r tan(alpha / 2)), and braking towards it at MPC_ACC_HOR).

        A waypoint the vehicle stops at (a hold time, a loiter, the last one) sets no limit: the
        position loop brings it to a stop there.
        """
        nxt = self._next_position(self.seq + 1)
        if nxt is None or item.command != CMD_WAYPOINT or item.param1 > 0:
            return math.inf
        o = self._leg_origin
        back = (o[0] - t[0], o[1] - t[1])
        ahead = (nxt[0] - t[0], nxt[1] - t[1])
        nb, na = math.hypot(*back), math.hypot(*ahead)
        if nb < 1e-3 or na < 1e-3:
            return math.inf
        cos = (back[0] * ahead[0] + back[1] * ahead[1]) / (nb * na)
        alpha = math.acos(max(-1.0, min(1.0, cos)))  # pi: straight on
        accel = self.params["MPC_ACC_HOR"]
        turn = math.sqrt(accel * acc * math.tan(min(alpha / 2, 1.5)))
        return math.sqrt(turn * turn + 2.0 * accel * max(0.0, dist - acc))

    def _next_position(self, seq: int) -> tuple[float, float] | None:
        """Where the first item from ``seq`` on that goes somewhere lies (north, east)."""
        for item in self.mission[seq:]:
            if item.command in (*WAYPOINT_COMMANDS, CMD_LAND):
                n, e, _ = self._item_target(item)
                return n, e
            if item.command in (CMD_RTL, CMD_DO_JUMP):
                return None
        return None

    def reposition(self, n: float, e: float, d: float | None, speed: float | None) -> None:
        """Fly to (n, e, d) and hold there (DO_REPOSITION: PX4 v1.15 does this in Hold)."""
        if d is None:
            d = self.est.pos[2]
        if speed is not None and speed > 0:
            self._cruise = speed
        self.set_mode(Mode.LOITER)
        self._hold = (n, e, d)
        pos = self.est.pos
        if math.hypot(n - pos[0], e - pos[1]) > 2.0:
            self._yaw_sp = math.atan2(e - pos[1], n - pos[0])

    # -- offboard, follow target, manual ------------------------------------------------------

    def _offboard_setpoint(self) -> Target:
        sp = self._offboard
        pos = self.est.pos
        if sp is None:
            return self._hold, None, False, None
        if sp.yaw is not None:
            self._yaw_sp = sp.yaw
        if sp.pos is not None:
            return sp.pos, None, False, None
        if sp.vel is not None:
            return (pos[0], pos[1], pos[2]), sp.vel[2], False, (sp.vel[0], sp.vel[1])
        return (pos[0], pos[1], pos[2]), None, False, None

    def _follow_setpoint(self) -> Target:
        """Stay FLW_TGT_DST from the target at FLW_TGT_FA off its course, FLW_TGT_HT up."""
        p, est = self.params, self.est
        tgt = self._follow
        if tgt is None or est.origin is None:
            return self._hold, None, False, None
        n, e = est.origin.project(tgt[0], tgt[1])
        adj = self._follow_adjust
        m = self._manual
        if m is not None and self._now - m[4] < 1.0:
            # Sticks adjust the follow geometry (PX4's FlightTaskAutoFollowTarget rates).
            dt = self.period
            adj[0] += (2.0 * m[2] - 1.0) * FOLLOW_HEIGHT_RATE * dt
            adj[1] += m[0] * FOLLOW_DISTANCE_RATE * dt
            adj[2] += m[1] * FOLLOW_ANGLE_RATE * dt
        want = self._follow_course + math.radians(p["FLW_TGT_FA"]) + adj[2]
        dist = max(p["FLW_TGT_DST"] + adj[1], 1.0)
        # Fly around the target to a new angle, at most FLW_TGT_MAX_VEL along the orbit (PX4's
        # orbit-angle trajectory), rather than through it.
        if self._follow_angle is None:
            self._follow_angle = want
        turn = math.remainder(want - self._follow_angle, math.tau)
        limit = max(p["FLW_TGT_MAX_VEL"], 0.1) / dist * self.period
        self._follow_angle += min(max(turn, -limit), limit)
        angle = self._follow_angle
        sp = (n + dist * math.cos(angle), e + dist * math.sin(angle))
        if math.hypot(n - est.pos[0], e - est.pos[1]) > 2.0:
            self._yaw_sp = math.atan2(e - est.pos[1], n - est.pos[0])  # face the target
        self._hold = (sp[0], sp[1], self._home_d() - p["FLW_TGT_HT"] - adj[0])
        return self._hold, None, False, None

    def _manual_setpoint(self) -> Target:
        """POSCTL/ALTCTL (and MANUAL, STABILIZED, ACRO as ALTCTL) from MANUAL_CONTROL sticks."""
        p, est = self.params, self.est
        pos = est.pos
        m = self._manual or (0.0, 0.0, 0.5, 0.0, self._now)
        x, y, z, r = m[0], m[1], m[2], m[3]
        if abs(r) > MANUAL_DEADZONE:
            self._yaw_sp += r * MANUAL_YAW_RATE * self.period
        thr = 2.0 * z - 1.0
        vz: float | None = None
        hold_d = self._hold[2]
        if abs(thr) > 2 * MANUAL_DEADZONE:
            vz = -thr * p["MPC_Z_VEL_MAX_UP"] if thr > 0 else -thr * p["MPC_Z_VEL_MAX_DN"]
            hold_d = pos[2]
        vxy: tuple[float, float] | None = None
        if abs(x) > MANUAL_DEADZONE or abs(y) > MANUAL_DEADZONE or self.mode != Mode.POSCTL:
            yaw = est.euler()[2]
            c, s = math.cos(yaw), math.sin(yaw)
            v = p["MPC_VEL_MANUAL"]
            vxy = ((x * c - y * s) * v, (x * s + y * c) * v)
            self._hold = (pos[0], pos[1], hold_d)
        else:
            self._hold = (self._hold[0], self._hold[1], hold_d)
        return self._hold, vz, False, vxy

    # -- control ----------------------------------------------------------------------------

    def _navigate_and_control(self) -> HilActuatorControls:
        est, p = self.est, self.params
        t_us = round(self._now * 1e6)
        if not self.armed:
            self._vz_sp = 0.0
            self._pos_sp = self._vel_sp = None
            return HilActuatorControls(t_us, [0.0] * 16, 0, 1)
        sp, vz_override, idle, vxy = self._setpoint()
        self._pos_sp, self._vel_sp = sp, None
        if idle:
            self._vz_sp = 0.0
            self.ctl.reset()
            if self.velocity_vehicle:
                return HilActuatorControls(
                    t_us,
                    [0.0, 0.0, 0.0, self._yaw_sp, *_ZEROS12],
                    MODE_FLAG_ARMED,
                    ACTUATOR_FLAG_VELOCITY | 1,
                )
            return HilActuatorControls(t_us, [0.1, 0.1, 0.1, 0.1, *_ZEROS12], MODE_FLAG_ARMED, 1)
        offboard = self._offboard if self.mode == Mode.OFFBOARD else None
        if offboard is not None and offboard.attitude is not None and not self.velocity_vehicle:
            thrust = offboard.thrust if offboard.thrust is not None else 0.0
            # Low thrust reads as "asked to descend" for the land detector.
            self._vz_sp = 1.0 if thrust < p["MPC_THR_HOVER"] else -1.0
            motors = self.ctl.attitude(
                self.period, offboard.attitude, thrust, est.rotation(), est.rates
            )
            return HilActuatorControls(t_us, [*motors, *_ZEROS12], MODE_FLAG_ARMED, 1)
        cruise = self._cruise or p["MPC_XY_CRUISE"]
        leg = self.mode == Mode.MISSION and sp == self._target
        if leg:
            cruise = min(cruise, self._leg_speed)
        up = (
            p["MPC_TKO_SPEED"] if self.landed or self.mode == Mode.TAKEOFF else p["MPC_Z_V_AUTO_UP"]
        )
        down = p["MPC_Z_V_AUTO_DN"]
        if self.mode == Mode.OFFBOARD and not self.landed:
            # Offboard setpoints go to PX4's position controller as they come (no flight task
            # plans a path for them): its limits are the controller's, MPC_XY_VEL_MAX and
            # MPC_Z_VEL_MAX_UP/DN, not the cruise speeds of the auto modes.
            cruise, up, down = p["MPC_XY_VEL_MAX"], p["MPC_Z_VEL_MAX_UP"], p["MPC_Z_VEL_MAX_DN"]
        vel_sp = position_control(
            est.pos,
            sp,
            cruise=cruise,
            up=up,
            down=down,
            vz_override=vz_override,
            origin=self._leg_origin if leg else None,
        )
        if vxy is not None:
            vel_sp = (vxy[0], vxy[1], vel_sp[2])
        vel = est.vel
        if self._blind():
            # No position: a blind descent, level, on the vertical speed alone (the horizontal
            # velocity estimate drifts without GPS). Level as PX4's Descend, which asks for no
            # horizontal acceleration: the tilt the integrator learnt against drag at cruise
            # would otherwise keep the vehicle flying on.
            vel_sp = (0.0, 0.0, vel_sp[2])
            vel = [0.0, 0.0, est.vel[2]]
            self.ctl.vel_int[0] = self.ctl.vel_int[1] = 0.0
        self._vz_sp = vel_sp[2]
        self._vel_sp = vel_sp
        if self.velocity_vehicle:
            return HilActuatorControls(
                t_us,
                [vel_sp[0], vel_sp[1], vel_sp[2], self._yaw_sp, *_ZEROS12],
                MODE_FLAG_ARMED,
                ACTUATOR_FLAG_VELOCITY | 1,
            )
        motors = self.ctl.update(self.period, vel, vel_sp, self._yaw_sp, est.rotation(), est.rates)
        for i in self.motors_off:
            if i < len(motors):
                motors[i] = 0.0
        return HilActuatorControls(t_us, [*motors, *_ZEROS12], MODE_FLAG_ARMED, 1)
