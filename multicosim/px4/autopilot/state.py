"""The state our autopilot's parts share.

The autopilot ([`firmware`][multicosim.firmware]) is one participant assembled from parts, one
concern per module: the flight logic (``commander``, ``navigator``, the controller in
``control``, the estimator in ``estimator``, sensor failures in
``failures``) and the MAVLink server (``offboard`` for the link itself,
``streams``, ``commands``, ``paramserver``, ``missions``). Each part is a
mixin over ``State``, which declares what they share.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import msgspec

from ...mavlink.dialect import SEV_INFO
from ..modes import Mode

if TYPE_CHECKING:
    from .control import MultirotorController
    from .estimator import Estimator
    from .params import Params


Home = tuple[float, float, float, float, float, float]  # n, e, d (local), lat, lon, alt
Vec3 = tuple[float, float, float]


class Item(msgspec.Struct, array_like=True, gc=False):
    """A stored mission item (MISSION_ITEM_INT fields)."""

    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float


class Setpoint(msgspec.Struct, gc=False):
    """An offboard setpoint (NED), each part None when the sender masked it out."""

    time: float
    pos: Vec3 | None = None
    vel: Vec3 | None = None
    yaw: float | None = None
    attitude: tuple[float, float, float, float] | None = None  # quaternion w, x, y, z
    thrust: float | None = None


class State:
    """What the autopilot's parts share (declared here, set in ``Autopilot.__init__``)."""

    # The participant.
    spec: Any
    period: float
    params: Params
    system_id: int  # MAVLink system id (MAV_SYS_ID at boot)
    est: Estimator
    ctl: MultirotorController
    velocity_vehicle: bool
    _now: float
    motors_off: set[int]  # motors stopped by failure injection (0-based)
    failures: dict[str, Any]  # sensor name: its injected failure
    # Commander.
    armed: bool
    mode: Mode
    landed: bool
    failsafe: str | None
    _offboard_lost: bool  # offboard lost: a fallback mode flies until setpoints return
    _armed_at: float
    _flew: bool
    _landed_at: float | None
    _ground_d: float
    _touch_since: float | None
    home: Home | None
    # Navigator.
    mission: list[Item]
    fence: list[Item]
    rally: list[Item]
    seq: int
    mission_state: int
    _jumps: dict[int, int]
    _phase: str
    _hold: Vec3
    _target: Vec3 | None
    _cruise: float | None
    _yaw_sp: float
    _vz_sp: float
    # The last position and velocity setpoints (local NED), for POSITION_TARGET_LOCAL_NED.
    _pos_sp: Vec3 | None
    _vel_sp: Vec3 | None
    _reached_at: float | None
    _offboard: Setpoint | None
    _manual: tuple[float, float, float, float, float] | None  # x, y, z, r, time
    _follow: tuple[float, float, float, float, float, float, float] | None
    _follow_adjust: list[float]  # height, distance, angle set by the sticks while following
    _follow_course: float  # rad, the target's course (from its velocity or its track)
    _follow_angle: float | None  # rad, where around the target the vehicle is headed now
    # Ground-station link.
    _d: Any
    mav: Any
    _out: list[bytes]
    _out_msgs: list[Any]  # per frame in _out, its message as decoded, or None
    _gcs: tuple[int, int]
    _dirty: set[str]
    _after_ack: list[Any]
    truth: Any

    if TYPE_CHECKING:  # provided by the parts

        def _send(self, msg: Any) -> None: ...
        def _text(self, text: str, severity: int = SEV_INFO) -> None: ...
        def set_mode(self, mode: Mode) -> str | None: ...
        def arm(self, force: bool = False) -> str | None: ...
        def disarm(self, force: bool = False) -> str | None: ...
        def arm_check(self) -> str | None: ...
        def _set_home(self) -> None: ...
        def _set_home_to(self, p: tuple[float, ...], frame: int) -> int: ...
        def _start_mission_item(self) -> None: ...
        def _item_reached(self) -> None: ...
        def inject_failure(self, unit: int, kind: int, instance: int) -> int: ...
        def message(self, name: str, **fields: Any) -> Any: ...
        def set_interval(self, name: str, interval_us: float) -> bool: ...
        def interval_us(self, name: str) -> int: ...
        def reposition(self, n: float, e: float, d: float | None, speed: float | None) -> None: ...
        def _autopilot_version(self) -> Any: ...
