"""How the ground station flies ArduPilot: its modes, parameters, mission and start sequence.

The ground station (``multicosim.mavlink.gcs``) speaks MAVLink's protocols to any autopilot;
this is what ArduPilot does differently from PX4:

* telemetry is asked for (SET_MESSAGE_INTERVAL): ArduPilot streams nothing unrequested;
* modes are ArduPilot's numbers (GUIDED, AUTO, RTL, LAND for the copter; HOLD, AUTO, RTL,
  GUIDED for the rover), named as ArduPilot names them;
* cruise speed and acceptance radius are ``WPNAV_SPEED``/``WPNAV_RADIUS`` (centimetres) on
  the copter, ``WP_SPEED``/``WP_RADIUS`` on the rover;
* the mission's item 0 is home (ArduPilot keeps its own there); the copter's starts with a
  takeoff, then the waypoints, then a land or return-to-launch item (a plan's items follow
  home as they are);
* arming happens in GUIDED once the estimator has a position (ArduPilot sets home then);
  MISSION_START switches to AUTO and, on the copter, lets it take off from the ground;
* the rover has no landing: ``end="land"`` stops it at the last waypoint (where its mission
  ends), ``"rtl"`` drives it home; then it is disarmed, as a copter disarms once landed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..mavlink.dialect import (
    CMD_ARM_DISARM,
    CMD_DO_SET_MODE,
    CMD_LAND,
    CMD_MISSION_START,
    CMD_RTL,
    CMD_SET_MSG_INTERVAL,
    CMD_TAKEOFF,
    CMD_WAYPOINT,
    MSG_ATTITUDE,
    MSG_EXTENDED_SYS_STATE,
    MSG_GLOBAL_POSITION_INT,
    MSG_HOME_POSITION,
    MSG_LOCAL_POSITION_NED,
    MSG_MISSION_CURRENT,
    MSG_SYS_STATUS,
)
from ..mavlink.gcs import GroundStation, MissionFailed, Procedure
from ..mavlink.mission import Configuration
from ..mavlink.plan_link import plan_items

__all__ = ["ArduPilotProcedure", "CopterProcedure", "RoverProcedure"]

CUSTOM_MODE_ENABLED = 1
STOPPED = 0.2  # m/s: a rover slower than this has stopped
MISSION_COMPLETE = 5  # MISSION_STATE_COMPLETE
RETRY = 1.0  # s between attempts at what ArduPilot refuses until its checks pass

_WAYPOINT_PARAMS = (0, 0, 0, 0)


def _modes(vehicle: str) -> dict[int, str]:
    from pymavlink import mavutil

    table: dict[int, str] = (
        mavutil.mode_mapping_acm if vehicle == "copter" else mavutil.mode_mapping_rover
    )
    return table


class ArduPilotProcedure(Procedure):
    """What ArduCopter and ArduRover share."""

    vehicle = "copter"
    guided = 4
    plan_offset = 1

    def __init__(self) -> None:
        self._modes = _modes(self.vehicle)

    def mode_label(self, heartbeat: Any) -> str:
        """ArduPilot's name of the mode (``GUIDED``, ``AUTO``, ``RTL``, ...)."""
        mode: int = heartbeat.custom_mode
        return self._modes.get(mode, str(mode))

    def prepare(self, gs: GroundStation, config: Configuration) -> None:
        """Ask for the telemetry the ground station records (ArduPilot streams none)."""
        fast = round(gs.spec.period * 1e6)
        for message, interval in (
            (MSG_GLOBAL_POSITION_INT, fast),
            (MSG_LOCAL_POSITION_NED, fast),
            (MSG_ATTITUDE, fast),
            (MSG_SYS_STATUS, fast),
            (MSG_EXTENDED_SYS_STATE, fast),
            (MSG_MISSION_CURRENT, fast),
            (MSG_HOME_POSITION, 1_000_000),
        ):
            if gs.command(CMD_SET_MSG_INTERVAL, message, interval) != 0:
                raise MissionFailed(f"ArduPilot refused to stream MAVLink message {message}")

    def mission_items(
        self, gs: GroundStation, config: Configuration, home_lat: float, home_lon: float
    ) -> list[Any]:
        """Home (item 0), the vehicle's own first items, the waypoints, then the end (or
        home and a plan's items as they are)."""
        items = [gs.item(0, CMD_WAYPOINT, params=_WAYPOINT_PARAMS, lat=home_lat, lon=home_lon)]
        if config.plan is not None:
            return items + plan_items(gs, config.plan.items, self.plan_offset, unset=0.0)
        items += self._start_items(gs, config, len(items))
        for wp in config.mission:
            items.append(
                gs.item(
                    len(items),
                    CMD_WAYPOINT,
                    params=(0, config.acceptance_radius, 0, 0),
                    lat=wp.lat,
                    lon=wp.lon,
                    alt=wp.alt,
                )
            )
        items += self._end_items(gs, config, len(items))
        return items

    def _start_items(self, gs: GroundStation, config: Configuration, seq: int) -> list[Any]:
        return []

    def _end_items(self, gs: GroundStation, config: Configuration, seq: int) -> list[Any]:
        if config.end == "rtl":
            return [gs.item(seq, CMD_RTL, params=_WAYPOINT_PARAMS)]
        return []

    def start(self, gs: GroundStation, config: Configuration) -> None:
        """GUIDED, arm (retrying while pre-arm checks still fail), MISSION_START."""
        if not _retry(gs, lambda: gs.command(CMD_DO_SET_MODE, CUSTOM_MODE_ENABLED, self.guided)):
            raise MissionFailed("GUIDED mode refused: " + gs.why("no position estimate"))
        if not _retry(gs, lambda: gs.command(CMD_ARM_DISARM, 1.0)):
            raise MissionFailed("arming refused: " + gs.why("pre-arm checks failed"))
        if not gs.wait(lambda: gs.armed, 3.0):
            raise MissionFailed(gs.why("arming was acknowledged but the vehicle is not armed"))
        result = gs.command(CMD_MISSION_START, 0.0, 0.0)
        if result != 0:
            raise MissionFailed("mission start refused: " + gs.why(f"result {result}"))


def _retry(gs: GroundStation, attempt: Callable[[], int], timeout: float = 30.0) -> bool:
    """Repeat ``attempt`` (a COMMAND_ACK result) until it is accepted or ``timeout`` passes."""
    deadline = gs.ctx.time + timeout
    while attempt() != 0:
        if gs.ctx.time >= deadline:
            return False
        gs.wait(lambda: False, RETRY)
    return True


class CopterProcedure(ArduPilotProcedure):
    """ArduCopter: takeoff, waypoints, land or RTL; WPNAV speed and radius in centimetres."""

    vehicle = "copter"
    guided = 4
    first_waypoint = 2

    def parameters(self, config: Configuration) -> list[tuple[str, float]]:
        """ArduCopter's waypoint speed and radius (cm/s, cm)."""
        return [
            ("WPNAV_SPEED", round(config.cruise_speed * 100.0, 1)),
            ("WPNAV_RADIUS", round(config.acceptance_radius * 100.0, 1)),
        ]

    def _start_items(self, gs: GroundStation, config: Configuration, seq: int) -> list[Any]:
        wps = config.mission
        takeoff = config.takeoff_alt if config.takeoff_alt is not None else wps[0].alt
        return [gs.item(seq, CMD_TAKEOFF, params=_WAYPOINT_PARAMS, alt=takeoff)]

    def _end_items(self, gs: GroundStation, config: Configuration, seq: int) -> list[Any]:
        if config.end == "land":
            last = config.mission[-1]
            return [gs.item(seq, CMD_LAND, params=_WAYPOINT_PARAMS, lat=last.lat, lon=last.lon)]
        return super()._end_items(gs, config, seq)


class RoverProcedure(ArduPilotProcedure):
    """ArduRover: waypoints, then stop there or drive home; WP speed and radius in metres."""

    vehicle = "rover"
    guided = 15

    def parameters(self, config: Configuration) -> list[tuple[str, float]]:
        """ArduRover's waypoint speed and radius (m/s, m)."""
        return [("WP_SPEED", config.cruise_speed), ("WP_RADIUS", config.acceptance_radius)]

    def finished(self, gs: GroundStation, config: Configuration, waypoints_done: bool) -> bool:
        """Done at the last waypoint (``hold``), stopped there (``land``) or home (``rtl``)."""
        if not gs.armed:
            raise MissionFailed(gs.why("disarmed before the mission completed"))
        if not waypoints_done:
            return False
        if config.end == "hold":
            return True
        # Its mission ends at the last waypoint ("land": ArduRover stops there) or home
        # ("rtl"); ArduRover says when it has arrived (MISSION_CURRENT's mission state).
        pos = gs.position
        stopped = pos is not None and math.hypot(pos.vx, pos.vy) * 0.01 <= STOPPED
        if gs.mission_state != MISSION_COMPLETE or not stopped:
            return False
        # Stopped where it should end: disarm, as a copter does once it has landed.
        if gs.command(CMD_ARM_DISARM, 0.0) != 0 or not gs.wait(lambda: not gs.armed, 3.0):
            raise MissionFailed(gs.why("the rover did not disarm at the end of its mission"))
        return True

    def landed(self, gs: GroundStation) -> bool:
        """A rover is always on the ground."""
        return True
