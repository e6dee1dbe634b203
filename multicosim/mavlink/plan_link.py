"""A QGroundControl plan over MAVLink: its items encoded, its areas uploaded, its waypoints found.

The ground station (``gcs``) flies a ``Plan`` item for item: the mission as
MISSION_ITEM_INTs (numbered from where the autopilot wants them), the geofence and rally
points with their own mission types, and the reports of reached items mapped back to the
plan's waypoints.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

from .dialect import (
    CMD_DO_JUMP,
    CMD_LAND,
    FRAME_MISSION,
    MISSION_TYPE_FENCE,
    MISSION_TYPE_MISSION,
    MISSION_TYPE_RALLY,
    NAV_COMMANDS,
)
from .mission import Configuration
from .plan import Plan, PlanItem

__all__ = ["Uplink", "plan_items", "upload_plan_areas", "waypoint_indices"]


class Uplink(Protocol):
    """What these need of the ground station: its encoder, target and mission upload."""

    mav: Any
    target: tuple[int, int]

    def upload(self, items: list[Any], timeout: float = ..., mission_type: int = ...) -> int:
        """Upload ``items``; the MISSION_ACK type (-1: no answer)."""
        ...

    def why(self, default: str) -> str:
        """The autopilot's last critical message, else ``default``."""
        ...


def plan_items(
    gs: Uplink,
    items: list[PlanItem],
    first: int,
    mission_type: int = MISSION_TYPE_MISSION,
    unset: float = math.nan,
) -> list[Any]:
    """``items`` as MISSION_ITEM_INTs numbered from ``first``, DO_JUMP targets to match.

    ``unset`` replaces the parameters a plan leaves unset (NaN: PX4 reads NaN as "keep
    what you have"; ArduPilot refuses NaN, and QGroundControl sends it 0 instead).
    """
    out = []
    for i, it in enumerate(items):
        p = it.params
        if not math.isnan(unset):
            p1, p2, p3, p4, lat, lon, alt = (unset if math.isnan(v) else v for v in p)
            p = (p1, p2, p3, p4, lat, lon, alt)
        if it.command == CMD_DO_JUMP:
            p = (p[0] + first, *p[1:])
        # Items without a position carry params 5 and 6 as integers, unscaled.
        scale = 1.0 if it.frame == FRAME_MISSION else 1e7
        out.append(
            gs.mav.mission_item_int_encode(
                *gs.target,
                first + i,
                it.frame,
                it.command,
                0,
                int(it.autocontinue),
                *p[:4],
                round(p[4] * scale),
                round(p[5] * scale),
                p[6],
                mission_type,
            )
        )
    return out


def upload_plan_areas(gs: Uplink, plan: Plan) -> str:
    """Upload the plan's geofence and rally points; "" or why an upload failed."""
    for what, mtype, items in (
        ("geofence", MISSION_TYPE_FENCE, plan.fence_items()),
        ("rally point", MISSION_TYPE_RALLY, plan.rally_items()),
    ):
        if not items:
            continue
        ack = gs.upload(plan_items(gs, items, 0, mtype), mission_type=mtype)
        if ack < 0:
            return f"{what} upload timed out"
        if ack != 0:
            return gs.why(f"{what} upload failed (MISSION_ACK {ack})")
    return ""


def waypoint_indices(
    config: Configuration, first_waypoint: int, plan_offset: int
) -> dict[int, int]:
    """Which of the configuration's waypoints each mission sequence number completes.

    A waypoint's own number, and those of the items after it that are no navigation
    (DO_ and camera commands): PX4 reports the last of these when it reaches the waypoint.
    ``first_waypoint`` numbers a configuration's own waypoints, ``plan_offset`` a plan's
    first item.
    """
    plan = config.plan
    if plan is None:
        return {first_waypoint + i: i for i in range(len(config.mission))}
    out: dict[int, int] = {}
    for index, i in enumerate(plan.waypoints()):
        for j in range(i, len(plan.items)):
            if j > i and plan.items[j].command in NAV_COMMANDS:
                break
            out[plan_offset + j] = index
    return out


def last_to_reach(config: Configuration) -> int:
    """The last of the configuration's waypoints the autopilot must report reached.

    A landing at a position of its own ends the mission when the vehicle has landed there
    (ArduCopter reports no item reached for it, PX4 does): it is not waited for. -1 when
    the mission has no other waypoint.
    """
    plan = config.plan
    count = len(config.mission)
    if plan is None:
        return count - 1
    items = plan.waypoints()
    while count and plan.items[items[count - 1]].command == CMD_LAND:
        count -= 1
    return count - 1
