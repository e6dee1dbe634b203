"""How the ground station flies PX4: its parameters, mission layout, modes and start sequence."""

from __future__ import annotations

import math
from typing import Any

from ..mavlink.dialect import (
    CMD_ARM_DISARM,
    CMD_LAND,
    CMD_MISSION_START,
    CMD_RTL,
    CMD_TAKEOFF,
    CMD_WAYPOINT,
    FRAME_MISSION,
)
from ..mavlink.gcs import GroundStation, MissionFailed, Procedure
from ..mavlink.mission import Configuration
from ..mavlink.plan_link import plan_items
from .modes import mode_label

__all__ = ["PX4Procedure"]


class PX4Procedure(Procedure):
    """PX4: MPC_XY_CRUISE and NAV_ACC_RAD; a takeoff item, the waypoints, land or RTL."""

    def mode_label(self, heartbeat: Any) -> str:
        """PX4's mode name (``AUTO.MISSION``) from its custom mode."""
        return mode_label(heartbeat.custom_mode)

    def parameters(self, config: Configuration) -> list[tuple[str, float]]:
        """PX4's cruise speed and acceptance radius."""
        return [("MPC_XY_CRUISE", config.cruise_speed), ("NAV_ACC_RAD", config.acceptance_radius)]

    def mission_items(
        self, gs: GroundStation, config: Configuration, home_lat: float, home_lon: float
    ) -> list[Any]:
        """Takeoff, waypoints, then land or RTL (a plan's items as they are)."""
        if config.plan is not None:
            return plan_items(gs, config.plan.items, 0)
        wps = config.mission
        takeoff = config.takeoff_alt if config.takeoff_alt is not None else wps[0].alt
        # Where it stands: PX4 checks the first item's distance from home.
        items = [gs.item(0, CMD_TAKEOFF, lat=home_lat, lon=home_lon, alt=takeoff)]
        for wp in wps:
            items.append(
                gs.item(
                    len(items),
                    CMD_WAYPOINT,
                    params=(0, config.acceptance_radius, 0, math.nan),
                    lat=wp.lat,
                    lon=wp.lon,
                    alt=wp.alt,
                )
            )
        last = wps[-1]
        if config.end == "land":
            items.append(gs.item(len(items), CMD_LAND, lat=last.lat, lon=last.lon))
        elif config.end == "rtl":
            # No position: PX4 refuses RTL in a global frame.
            items.append(gs.item(len(items), CMD_RTL, frame=FRAME_MISSION, params=(0, 0, 0, 0)))
        return items

    def start(self, gs: GroundStation, config: Configuration) -> None:
        """Arm, then MISSION_START; MissionFailed if PX4 refuses either."""
        # PX4 checks a mission after acknowledging it and refuses to start it until then
        # ("No valid mission"); MISSION_CURRENT's total says when it has taken it.
        gs.wait(lambda: gs.mission_total in (-1, gs.uploaded), 5.0)
        result = gs.command(CMD_ARM_DISARM, 1.0)
        if result != 0:
            raise MissionFailed("arming refused: " + gs.why(f"COMMAND_ACK result {result}"))
        # The armed state is the HEARTBEAT's: one sent before the ACK may still be the last
        # one seen, so wait for a heartbeat that says armed.
        if not gs.wait(lambda: gs.armed, 3.0):
            raise MissionFailed(gs.why("arming was acknowledged but the vehicle is not armed"))
        result = gs.command(CMD_MISSION_START, 0.0, 0.0)
        if result != 0:
            raise MissionFailed("mission start refused: " + gs.why(f"result {result}"))
