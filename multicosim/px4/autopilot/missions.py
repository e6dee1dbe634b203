"""The MAVLink mission protocol: missions, geofences and rally points, up and down.

Uploads (MISSION_COUNT, then MISSION_REQUEST_INT per item with retransmission, MISSION_ACK)
are checked as PX4 checks them: navigation items in a global frame (a return-to-launch
item also in the mission frame, as MAVSDK sends it), DO_JUMP to an existing item, any
other command MAVLink defines (the navigator notes those it has nothing to do for),
coordinates in range and inside the geofence parameters and the uploaded geofence. Geofence
(polygon vertices, circles) and rally point lists are stored; RTL returns to the closest
rally point. A legacy MISSION_REQUEST is answered with the float MISSION_ITEM, as PX4 does.
"""

from __future__ import annotations

import math
from typing import Any

from ...core.geo import LocalProjection
from ...mavlink.dialect import (
    CMD_DO_JUMP,
    CMD_FENCE_CIRCLE_EXCLUSION,
    CMD_FENCE_CIRCLE_INCLUSION,
    CMD_FENCE_POLYGON_EXCLUSION,
    CMD_FENCE_POLYGON_INCLUSION,
    CMD_RALLY_POINT,
    FRAME_GLOBAL,
    FRAME_GLOBAL_INT,
    FRAME_GLOBAL_REL,
    FRAME_GLOBAL_REL_INT,
    FRAME_MISSION,
    MISSION_ACCEPTED,
    MISSION_ERROR,
    MISSION_INVALID,
    MISSION_INVALID_SEQUENCE,
    MISSION_OPERATION_CANCELLED,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_NOT_STARTED,
    MISSION_TYPE_FENCE,
    MISSION_TYPE_MISSION,
    MISSION_TYPE_RALLY,
    MISSION_UNSUPPORTED,
    MISSION_UNSUPPORTED_FRAME,
    NAV_COMMANDS,
    SEV_CRITICAL,
    SEV_WARNING,
)
from ...mavlink.plan import command_name
from ..items import Frame, taken
from ..modes import Mode
from .geofence import inside_fence
from .state import Item, State

__all__ = ["Missions"]

GLOBAL_FRAMES = (FRAME_GLOBAL, FRAME_GLOBAL_REL, FRAME_GLOBAL_INT, FRAME_GLOBAL_REL_INT)
FENCE_COMMANDS = (
    CMD_FENCE_POLYGON_INCLUSION,
    CMD_FENCE_POLYGON_EXCLUSION,
    CMD_FENCE_CIRCLE_INCLUSION,
    CMD_FENCE_CIRCLE_EXCLUSION,
)
MISSION_TYPES = (MISSION_TYPE_MISSION, MISSION_TYPE_FENCE, MISSION_TYPE_RALLY)


class Missions(State):
    """The mission protocol (a part of ``Autopilot``)."""

    _upload: dict[str, Any] | None

    def _items(self, mtype: int) -> list[Item]:
        if mtype == MISSION_TYPE_FENCE:
            return self.fence
        if mtype == MISSION_TYPE_RALLY:
            return self.rally
        return self.mission

    def _mission_ack(self, result: int, mission_type: int = MISSION_TYPE_MISSION) -> None:
        s, c = self._gcs
        self._send(self._d.MAVLink_mission_ack_message(s, c, result, mission_type))

    def _on_mission_count(self, m: Any) -> None:
        mtype = getattr(m, "mission_type", 0)
        if mtype not in MISSION_TYPES:
            self._mission_ack(MISSION_UNSUPPORTED, mtype)
            return
        if m.count == 0:
            self._clear(mtype)
            self._mission_ack(MISSION_ACCEPTED, mtype)
            return
        self._upload = {"count": m.count, "items": [], "tries": 0, "deadline": 0.0, "type": mtype}
        self._request_item()

    def _request_item(self) -> None:
        up = self._upload
        assert up is not None
        s, c = self._gcs
        self._send(self._d.MAVLink_mission_request_int_message(s, c, len(up["items"]), up["type"]))
        up["deadline"] = self._now + 0.5
        up["tries"] += 1

    def _upload_tick(self) -> None:
        up = self._upload
        assert up is not None
        if self._now < up["deadline"]:
            return
        if up["tries"] >= 5:
            self._upload = None
            self._mission_ack(MISSION_OPERATION_CANCELLED, up["type"])
            self._text("Mission upload timed out", SEV_WARNING)
            return
        self._request_item()

    def _on_mission_item_int(self, m: Any) -> None:
        up = self._upload
        if up is None or getattr(m, "mission_type", 0) != up["type"]:
            return
        if m.seq != len(up["items"]):
            if m.seq < len(up["items"]):
                return  # a duplicate: our request crossed it; the next one is on its way
            self._upload = None
            self._mission_ack(MISSION_INVALID_SEQUENCE, up["type"])
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
        mtype = up["type"]
        items: list[Item] = up["items"]
        result, why = self._check(items, mtype)
        if result != MISSION_ACCEPTED:
            self._text(f"Mission rejected: {why}", SEV_CRITICAL)
            self._mission_ack(result, mtype)
            return
        if mtype == MISSION_TYPE_FENCE:
            self.fence = items
        elif mtype == MISSION_TYPE_RALLY:
            self.rally = items
        else:
            self.mission = items
            self.seq = 0
            self._jumps = {}
            self.mission_state = MISSION_STATE_NOT_STARTED
            self._cruise = None
            if self.mode == Mode.MISSION:
                self._start_mission_item()
            self._dirty.add("MISSION_CURRENT")
        self._mission_ack(MISSION_ACCEPTED, mtype)

    def _on_mission_item(self, m: Any) -> None:
        # The deprecated float variant: same fields, degrees instead of degE7.
        int_frame = {FRAME_GLOBAL: FRAME_GLOBAL_INT, FRAME_GLOBAL_REL: FRAME_GLOBAL_REL_INT}
        self._on_mission_item_int(_FloatItem(m, int_frame.get(m.frame, m.frame)))

    def _check(self, items: list[Item], mtype: int) -> tuple[int, str]:
        for it in items:
            if abs(it.x) > 900_000_000 or abs(it.y) > 1_800_000_000:
                return MISSION_INVALID, f"item {it.seq}: coordinates out of range"
            if mtype == MISSION_TYPE_FENCE:
                if it.command not in FENCE_COMMANDS:
                    return MISSION_UNSUPPORTED, f"fence item {it.seq}: command {it.command}"
                if it.frame not in (FRAME_GLOBAL, FRAME_GLOBAL_INT):
                    return MISSION_UNSUPPORTED_FRAME, f"fence item {it.seq}: frame {it.frame}"
            elif mtype == MISSION_TYPE_RALLY:
                if it.command != CMD_RALLY_POINT:
                    return MISSION_UNSUPPORTED, f"rally item {it.seq}: command {it.command}"
                if it.frame not in GLOBAL_FRAMES:
                    return MISSION_UNSUPPORTED_FRAME, f"rally item {it.seq}: frame {it.frame}"
        if mtype == MISSION_TYPE_MISSION:
            return self._check_mission(items)
        return MISSION_ACCEPTED, ""

    def _check_mission(self, items: list[Item]) -> tuple[int, str]:
        fence_r = self.params["GF_MAX_HOR_DIST"]
        fence_h = self.params["GF_MAX_VER_DIST"]
        ref = self.home
        proj = LocalProjection(ref[3], ref[4]) if ref is not None else None
        for it in items:
            cmd = it.command
            if it.frame not in (*GLOBAL_FRAMES, FRAME_MISSION):
                return MISSION_UNSUPPORTED_FRAME, f"item {it.seq}: frame {it.frame} unsupported"
            frame: Frame = "mission" if it.frame == FRAME_MISSION else "global"
            ack = taken(cmd, frame, it.param1)
            if ack != MISSION_ACCEPTED:
                name = command_name(cmd) or f"command {cmd}"
                return ack, f"item {it.seq}: {name} unsupported in the {frame} frame"
            if cmd == CMD_DO_JUMP and not 0 <= it.param1 < len(items):
                return MISSION_ERROR, f"item {it.seq}: DO_JUMP to a missing item"
            if proj is not None and ref is not None and cmd in NAV_COMMANDS and (it.x or it.y):
                n, e = proj.project(it.x * 1e-7, it.y * 1e-7)
                if fence_r > 0 and math.hypot(n, e) > fence_r:
                    return MISSION_ERROR, f"item {it.seq} outside geofence"
                rel = it.z - ref[5] if it.frame in (FRAME_GLOBAL, FRAME_GLOBAL_INT) else it.z
                if fence_h > 0 and rel > fence_h:
                    return MISSION_ERROR, f"item {it.seq} above geofence"
            positioned = cmd in NAV_COMMANDS and (it.x or it.y)
            if positioned and not inside_fence(self.fence, it.x * 1e-7, it.y * 1e-7):
                return MISSION_ERROR, f"geofence violation, item {it.seq}"
        return MISSION_ACCEPTED, ""

    def _clear(self, mtype: int) -> None:
        if mtype == MISSION_TYPE_FENCE:
            self.fence = []
            return
        if mtype == MISSION_TYPE_RALLY:
            self.rally = []
            return
        self.mission = []
        self.seq = 0
        self.mission_state = MISSION_STATE_NO_MISSION
        if self.mode == Mode.MISSION:
            self.set_mode(Mode.LOITER)
        self._dirty.add("MISSION_CURRENT")

    def _on_mission_clear_all(self, m: Any) -> None:
        mtype = getattr(m, "mission_type", 0)
        if mtype in MISSION_TYPES:
            self._clear(mtype)
        self._mission_ack(MISSION_ACCEPTED, mtype)

    def _on_mission_request_list(self, m: Any) -> None:
        mtype = getattr(m, "mission_type", 0)
        count = len(self._items(mtype)) if mtype in MISSION_TYPES else 0
        s, c = self._gcs
        self._send(self._d.MAVLink_mission_count_message(s, c, count, mtype))

    def _stored(self, m: Any) -> Item | None:
        mtype = getattr(m, "mission_type", 0)
        items = self._items(mtype) if mtype in MISSION_TYPES else []
        if not 0 <= m.seq < len(items):
            self._mission_ack(MISSION_INVALID_SEQUENCE, mtype)
            return None
        item: Item = items[m.seq]
        return item

    def _on_mission_request_int(self, m: Any) -> None:
        it = self._stored(m)
        if it is None:
            return
        s, c = self._gcs
        current = int(it.seq == self.seq) if m.mission_type == MISSION_TYPE_MISSION else 0
        self._send(
            self._d.MAVLink_mission_item_int_message(
                s,
                c,
                it.seq,
                it.frame,
                it.command,
                current,
                it.autocontinue,
                it.param1,
                it.param2,
                it.param3,
                it.param4,
                it.x,
                it.y,
                it.z,
                m.mission_type,
            )
        )

    def _on_mission_request(self, m: Any) -> None:
        it = self._stored(m)
        if it is None:
            return
        s, c = self._gcs
        frame = {FRAME_GLOBAL_INT: FRAME_GLOBAL, FRAME_GLOBAL_REL_INT: FRAME_GLOBAL_REL}.get(
            it.frame, it.frame
        )
        current = int(it.seq == self.seq) if m.mission_type == MISSION_TYPE_MISSION else 0
        self._send(
            self._d.MAVLink_mission_item_message(
                s,
                c,
                it.seq,
                frame,
                it.command,
                current,
                it.autocontinue,
                it.param1,
                it.param2,
                it.param3,
                it.param4,
                it.x * 1e-7,
                it.y * 1e-7,
                it.z,
                m.mission_type,
            )
        )

    def _on_mission_set_current(self, m: Any) -> None:
        if 0 <= m.seq < len(self.mission):
            self.seq = m.seq
            if self.mission[m.seq].command == CMD_DO_JUMP:
                # PX4 v1.15 takes the index verbatim and loads the DO_JUMP itself as the
                # current item, without resolving the jump (navigator/mission_base.cpp,
                # MissionBase::updateMavlinkMission: `_mission = new_mission;`, then
                # set_mission_items()): an idle setpoint, and the mission waits there for
                # good. The navigator holds (PX4 resolves the jump only in later releases).
                self._phase = ""
                self._target = None
                self._hold = (self.est.pos[0], self.est.pos[1], self.est.pos[2])
            else:
                self._start_mission_item()
            self._dirty.add("MISSION_CURRENT")


class _FloatItem:
    """A MISSION_ITEM seen as a MISSION_ITEM_INT."""

    def __init__(self, m: Any, frame: int) -> None:
        self.__dict__.update({k: getattr(m, k) for k in m.get_fieldnames()})
        self.frame = frame
        self.x = round(m.x * 1e7)
        self.y = round(m.y * 1e7)
