"""The conformance recording's mission items: which ones PX4 takes, in which frame.

``item_answers`` uploads, one at a time, a two-item mission (a takeoff, then the item)
for every mission command PX4 v1.15's MAVLink mission manager parses and for its near
neighbours it does not, each in a global frame and in the mission frame, and records PX4's
MISSION_ACK: accepted, unsupported, or a parameter refused. (PX4 v1.15 checks a mission's
feasibility only when it starts flying it.) Waits are on the autopilot's simulated clock.
"""

from __future__ import annotations

import math

from ..mavlink.dialect import CMD_TAKEOFF, FRAME_GLOBAL_REL_INT, FRAME_MISSION, MSG_HOME_POSITION
from ..mavlink.plan import command_name
from .probe import Probe

__all__ = ["ITEM_QUESTIONS", "item_answers", "item_key"]

# Parameters 1-4 an item is sent with where zeros would not be what a user writes.
_PARAMS: dict[int, tuple[float, float, float, float]] = {
    17: (0.0, 0.0, 0.0, math.nan),  # loiter unlimited: heading unchanged
    19: (5.0, 0.0, 0.0, math.nan),  # loiter 5 s
    80: (3.0, 0.0, 0.0, 0.0),  # ROI at a location (MAV_ROI_LOCATION)
    93: (5.0, -1.0, -1.0, -1.0),  # delay 5 s
    112: (5.0, 0.0, 0.0, 0.0),  # wait 5 s
    114: (10.0, 0.0, 0.0, 0.0),  # 10 m before the next waypoint
    177: (0.0, 1.0, 0.0, 0.0),  # back to item 0, once
    178: (1.0, 3.0, -1.0, 0.0),  # ground speed 3 m/s
    179: (1.0, 0.0, 0.0, 0.0),  # home where the vehicle is
    201: (3.0, 0.0, 0.0, 0.0),  # ROI at a location
    2000: (0.0, 1.0, 1.0, 0.0),  # one picture
}

GLOBAL_COMMANDS = (
    *(16, 17, 18, 19, 20, 21, 22, 30, 31, 80, 82, 84, 85, 93, 178, 195, 201, 212, 400),
    *(4501, 5000),
)
"""Commands asked in a global frame (with a position 11 m north of home, 10 m up)."""

MISSION_FRAME_COMMANDS = (
    *(16, 20, 22, 93, 112, 114, 115, 176, 177, 178, 179, 181, 183, 187, 189, 196, 197, 200),
    *(201, 203, 204, 205, 206, 211, 214, 260, 530, 531, 532, 534, 1000, 1001, 2000, 2001),
    *(2003, 2500, 2501, 3000, 42600, 212, 400),
)
"""Commands asked in the mission frame (no position)."""

ITEM_QUESTIONS = [(c, FRAME_GLOBAL_REL_INT) for c in GLOBAL_COMMANDS] + [
    (c, FRAME_MISSION) for c in MISSION_FRAME_COMMANDS
]
"""Every (command, frame) asked, in the order asked."""


def item_key(command: int, frame: int) -> str:
    """The answer's key: the command's MAVLink name without ``MAV_CMD_``, and its frame."""
    where = "mission frame" if frame == FRAME_MISSION else "global"
    return f"{command_name(command).removeprefix('MAV_CMD_')} ({where})"


def item_answers(link: Probe) -> dict[str, int | None]:
    """For each of ``ITEM_QUESTIONS``, the MISSION_ACK type of its upload."""
    home = link.wait(lambda m: m.get_type() == "HOME_POSITION", 5.0)
    if home is None:
        link.command("REQUEST_MESSAGE", MSG_HOME_POSITION)
        home = link.wait(lambda m: m.get_type() == "HOME_POSITION", 5.0)
    lat, lon = (home.latitude, home.longitude) if home is not None else (473977420, 85455940)
    takeoff = (0, FRAME_GLOBAL_REL_INT, CMD_TAKEOFF, 0.0, 0.0, 0.0, math.nan, lat, lon, 10.0)
    out: dict[str, int | None] = {}
    for command, frame in ITEM_QUESTIONS:
        p1, p2, p3, p4 = _PARAMS.get(command, (0.0, 0.0, 0.0, 0.0))
        if frame == FRAME_MISSION:
            item = (1, frame, command, p1, p2, p3, p4, 0, 0, 0.0)
        else:
            item = (1, frame, command, p1, p2, p3, p4, lat + 1000, lon, 10.0)
        out[item_key(command, frame)] = link.upload([takeoff, item])["ack"]
    link.catch_up()
    link.mav.mission_clear_all_send(*link.target, 0)
    link.wait(lambda m: m.get_type() == "MISSION_ACK", 1.0)
    return out
