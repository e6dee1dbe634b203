"""PX4 v1.15's mission items: which commands it takes in which frame, and how a multicopter
flies each, as the built-in autopilot does it.

The frames are what real PX4 v1.15.4 acknowledges (its MAVLink mission manager, recorded by
``conformance_items`` into the conformance file); anything else it refuses with
``MAV_MISSION_UNSUPPORTED`` (or ``MAV_MISSION_UNSUPPORTED_FRAME`` for a frame it has no use
for). The PX4 guide's table of items is checked against ``ITEMS``.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

from ..mavlink.plan import command_name

__all__ = ["ITEMS", "ROI_COMMANDS", "Frame", "Item", "table", "taken"]

Frame = Literal["global", "mission"]
"""A global frame (a position; relative or AMSL altitude) or the mission frame (none)."""


class Item(NamedTuple):
    """One mission command PX4 takes: the frames it is given in and what flying it does."""

    frames: tuple[Frame, ...]
    flown: str


ROI_COMMANDS = (80, 201)
"""NAV_ROI and DO_SET_ROI: taken in both frames, their mode (param 1) checked per frame."""

_GLOBAL: tuple[Frame, ...] = ("global",)
_MISSION: tuple[Frame, ...] = ("mission",)
_NOTED = "passed with a notice: nothing in our world to act on"

ITEMS: dict[int, Item] = {
    16: Item(_GLOBAL, "flown: hold time, acceptance radius"),
    17: Item(_GLOBAL, "flown: held there until the mission changes"),
    19: Item(_GLOBAL, "flown: held there for its time"),
    21: Item(_GLOBAL, "flown: to its position (if it has one) at its height, then landed"),
    22: Item(_GLOBAL, "flown: straight up where it stands, then to its position if it has one"),
    31: Item(_GLOBAL, "flown as a waypoint at the item's altitude"),
    80: Item(("global", "mission"), _NOTED),
    84: Item(_GLOBAL, _NOTED + " (VTOL)"),
    85: Item(_GLOBAL, _NOTED + " (VTOL)"),
    195: Item(_GLOBAL, _NOTED),
    201: Item(("global", "mission"), _NOTED),
    4501: Item(_GLOBAL, _NOTED + " (a fixed-wing gate)"),
    20: Item(_MISSION, "flown: return to launch (or the closest rally point) and land"),
    93: Item(_MISSION, "flown: held at the last item's position for param 1 seconds"),
    112: Item(_MISSION, _NOTED),
    114: Item(_MISSION, _NOTED),
    177: Item(_MISSION, "flown: jump to an item, param 2 times"),
    178: Item(_MISSION, "flown: cruise speed param 2 (every speed type; -1 keeps it)"),
    179: Item(_MISSION, "flown: home here (param 1 = 1) or at the item's position"),
    187: Item(_MISSION, _NOTED),
    189: Item(_MISSION, _NOTED + " (a landing sequence's start)"),
    196: Item(_MISSION, _NOTED),
    197: Item(_MISSION, _NOTED),
    200: Item(_MISSION, _NOTED),
    203: Item(_MISSION, _NOTED),
    204: Item(_MISSION, _NOTED),
    205: Item(_MISSION, _NOTED),
    206: Item(_MISSION, _NOTED),
    211: Item(_MISSION, _NOTED),
    214: Item(_MISSION, _NOTED),
    260: Item(_MISSION, _NOTED),
    530: Item(_MISSION, _NOTED),
    532: Item(_MISSION, _NOTED),
    1000: Item(_MISSION, _NOTED),
    1001: Item(_MISSION, _NOTED),
    2000: Item(_MISSION, _NOTED),
    2001: Item(_MISSION, _NOTED),
    2003: Item(_MISSION, _NOTED),
    2500: Item(_MISSION, _NOTED),
    2501: Item(_MISSION, _NOTED),
    3000: Item(_MISSION, _NOTED + " (VTOL)"),
    42600: Item(_MISSION, _NOTED),
    5000: Item(_GLOBAL, _NOTED + " (a fence return point: PX4 flies none in a mission)"),
}
"""Every mission command PX4 v1.15 takes from a ground station, by number (fence and rally
items go in their own lists)."""

_ROI_MODES: dict[Frame, tuple[int, ...]] = {"global": (0, 3), "mission": (0, 1, 2)}


def taken(command: int, frame: Frame, param1: float) -> int:
    """PX4's MISSION_ACK type for ``command`` in ``frame``: 0 taken, 3 unsupported, 6 its
    param 1 refused (a region of interest's mode that frame has no use for)."""
    if command in ROI_COMMANDS:
        return 0 if int(param1) in _ROI_MODES[frame] else 6
    item = ITEMS.get(command)
    return 0 if item is not None and frame in item.frames else 3


def table() -> str:
    """``ITEMS`` as the PX4 guide's Markdown table: global-frame items first."""
    rows = ["| Item | Frame | How it is flown |", "| --- | --- | --- |"]
    for command, item in sorted(ITEMS.items(), key=lambda kv: (kv[1].frames[0], kv[0])):
        name = command_name(command).removeprefix("MAV_CMD_")
        rows.append(f"| `{name}` ({command}) | {', '.join(item.frames)} | {item.flown} |")
    return "\n".join(rows)
