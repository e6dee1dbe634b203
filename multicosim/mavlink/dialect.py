"""MAVLink 2 (dialect ``common``, or another of pymavlink's) through pymavlink, and its numbers.

What an autopilot puts in HEARTBEAT.custom_mode is its own: PX4's encoding is in
``multicosim.px4.modes``, ArduPilot's in [`multicosim.ardupilot`][multicosim.ardupilot].
"""

from __future__ import annotations

import struct
from collections import deque
from types import ModuleType
from typing import Any

from ..core.deps import require

__all__ = ["decode_frames", "dialect", "new_link", "pack_scalar"]

# MAVLink numbers (common dialect), spelled out to keep lookups cheap; every module that
# speaks MAVLink takes them from here.
MAV_TYPE_QUADROTOR, MAV_TYPE_GCS = 2, 6
MAV_AUTOPILOT_INVALID, MAV_AUTOPILOT_PX4 = 8, 12
MAV_STATE_STANDBY, MAV_STATE_ACTIVE, MAV_STATE_CRITICAL = 3, 4, 5
MODE_FLAG_CUSTOM, MODE_FLAG_AUTO, MODE_FLAG_GUIDED = 1, 4, 8
MODE_FLAG_STABILIZE, MODE_FLAG_MANUAL, MODE_FLAG_ARMED = 16, 64, 128
LANDED_ON_GROUND, LANDED_IN_AIR, LANDED_TAKEOFF, LANDED_LANDING = 1, 2, 3, 4
RESULT_ACCEPTED, RESULT_TEMP_REJECTED, RESULT_DENIED = 0, 1, 2
RESULT_UNSUPPORTED, RESULT_FAILED = 3, 4
MISSION_ACCEPTED, MISSION_ERROR, MISSION_UNSUPPORTED_FRAME = 0, 1, 2
MISSION_UNSUPPORTED, MISSION_INVALID, MISSION_INVALID_SEQUENCE = 3, 5, 13
MISSION_OPERATION_CANCELLED = 15
MISSION_TYPE_MISSION, MISSION_TYPE_FENCE, MISSION_TYPE_RALLY = 0, 1, 2
MISSION_STATE_NO_MISSION, MISSION_STATE_NOT_STARTED = 1, 2
MISSION_STATE_ACTIVE, MISSION_STATE_PAUSED, MISSION_STATE_COMPLETE = 3, 4, 5
FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_REL, FRAME_GLOBAL_INT, FRAME_GLOBAL_REL_INT = (
    0,
    2,
    3,
    5,
    6,
)
FRAME_LOCAL_NED, FRAME_LOCAL_OFFSET_NED, FRAME_BODY_NED, FRAME_BODY_OFFSET_NED = 1, 7, 8, 9
CMD_WAYPOINT, CMD_LOITER_UNLIM, CMD_LOITER_TIME = 16, 17, 19
CMD_RTL, CMD_LAND, CMD_TAKEOFF = 20, 21, 22
CMD_LOITER_TO_ALT, CMD_DELAY = 31, 93
CMD_DO_SET_MODE, CMD_DO_JUMP, CMD_DO_CHANGE_SPEED, CMD_DO_SET_HOME = 176, 177, 178, 179
CMD_DO_REPOSITION, CMD_MISSION_START = 192, 300
CMD_ARM_DISARM, CMD_GET_HOME, CMD_INJECT_FAILURE = 400, 410, 420
CMD_GET_MSG_INTERVAL, CMD_SET_MSG_INTERVAL = 510, 511
CMD_REQUEST_MESSAGE, CMD_REQUEST_CAPABILITIES = 512, 520
CMD_FENCE_POLYGON_INCLUSION, CMD_FENCE_POLYGON_EXCLUSION = 5001, 5002
CMD_FENCE_CIRCLE_INCLUSION, CMD_FENCE_CIRCLE_EXCLUSION, CMD_RALLY_POINT = 5003, 5004, 5100
FORCE_MAGIC = 21196
SEV_CRITICAL, SEV_WARNING, SEV_NOTICE, SEV_INFO = 2, 4, 5, 6
NAV_COMMANDS = {
    *(CMD_WAYPOINT, CMD_LOITER_UNLIM, CMD_LOITER_TIME, CMD_RTL, CMD_LAND, CMD_TAKEOFF),
    *(CMD_LOITER_TO_ALT, CMD_DELAY),
}
# Message ids (for REQUEST_MESSAGE and SET_MESSAGE_INTERVAL).
MSG_HEARTBEAT, MSG_SYS_STATUS, MSG_ATTITUDE, MSG_LOCAL_POSITION_NED = 0, 1, 30, 32
MSG_GLOBAL_POSITION_INT, MSG_MISSION_CURRENT, MSG_GPS_GLOBAL_ORIGIN = 33, 42, 49
MSG_HIL_STATE_QUATERNION, MSG_AUTOPILOT_VERSION, MSG_HOME_POSITION = 115, 148, 242
MSG_EXTENDED_SYS_STATE, MSG_FLIGHT_INFORMATION, MSG_PROTOCOL_VERSION = 245, 264, 300
# POSITION_TARGET_TYPEMASK bits: what a position target leaves unset.
TARGET_IGNORE_POSITION, TARGET_IGNORE_VELOCITY = 1 | 2 | 4, 8 | 16 | 32
TARGET_IGNORE_ACCEL, TARGET_IGNORE_YAW, TARGET_IGNORE_YAW_RATE = 64 | 128 | 256, 1024, 2048
# SYS_STATUS sensor bits (MAV_SYS_STATUS_SENSOR) beyond the sensors themselves.
AHRS_BIT, PREARM_BIT = 0x200000, 0x10000000

_dialects: dict[str, ModuleType] = {}


def dialect(name: str = "common") -> ModuleType:
    """pymavlink's MAVLink 2 dialect module ``name`` (imported on first use).

    ``common`` is what PX4 speaks; ``ardupilotmega`` adds ArduPilot's own messages.
    """
    module = _dialects.get(name)
    if module is None:
        module = require(f"pymavlink.dialects.v20.{name}", "mavlink")
        _dialects[name] = module
    return module


def new_link(system: int, component: int, dialect_name: str = "common") -> Any:
    """A MAVLink 2 encoder/parser for one system/component (no file, packets are returned)."""
    mav = dialect(dialect_name).MAVLink(None, srcSystem=system, srcComponent=component)
    mav.robust_parsing = True
    return mav


_HEADER = struct.Struct("<BBBBBBBHB")
_CRC = struct.Struct("<H")
_scalar: dict[int, Any] = {}  # msgid -> class, for messages of scalar fields only


def scalar_class(msgid: int) -> Any:
    """The message class of ``msgid`` if its fields are all scalars (``pack_scalar``)."""
    cls = _scalar.get(msgid, False)
    if cls is False:
        cls = dialect().mavlink_map.get(msgid)
        if cls is not None and (
            any(n != 1 for n in cls.lengths) or b"s" in bytes(cls.native_format)
        ):
            cls = None  # arrays and strings take pymavlink's general path
        _scalar[msgid] = cls
    return cls


def pack_scalar(mav: Any, cls: Any, *values: Any, keep: list[Any] | None = None) -> bytes:
    """A MAVLink 2 frame of ``cls`` (scalar fields, ``values`` in wire order) from ``mav``.

    Byte for byte what pymavlink's ``pack`` produces (trailing zeros trimmed, CRC with
    crc_extra), without its per-message overhead; used for the high-rate telemetry. With
    ``keep``, the message as a receiver decodes it is appended there (see ``remember``).
    """
    payload = cls.unpacker.pack(*values)
    n = len(payload)
    while n > 1 and payload[n - 1] == 0:
        n -= 1
    mid = cls.id
    seq = mav.seq
    mav.seq = (seq + 1) & 0xFF
    if keep is not None:
        t = cls.unpacker.unpack(payload)
        m = cls(*[t[i] for i in cls.orders])
        m._header = dialect().MAVLink_header(mid, 0, 0, n, seq, mav.srcSystem, mav.srcComponent)
        keep.append(m)
    buf = (
        _HEADER.pack(0xFD, n, 0, 0, seq, mav.srcSystem, mav.srcComponent, mid & 0xFFFF, mid >> 16)
        + payload[:n]
    )
    crc = dialect().x25crc(buf[1:] + bytes((cls.crc_extra,))).crc
    return bytes(buf + _CRC.pack(crc))


def _decode_scalar(cls: Any, frame: bytes, n: int) -> Any:
    d = dialect()
    if (
        d.x25crc(frame[1 : 10 + n] + bytes((cls.crc_extra,))).crc
        != _CRC.unpack_from(frame, 10 + n)[0]
    ):
        raise ValueError("bad CRC")
    size = cls.unpacker.size
    payload = frame[10 : 10 + n]
    if n < size:
        payload += bytes(size - n)
    t = cls.unpacker.unpack(payload[:size])
    m = cls(*[t[i] for i in cls.orders])
    m._header = d.MAVLink_header(cls.id, 0, 0, n, frame[4], frame[5], frame[6])
    m._msgbuf = frame
    return m


_packed: deque[tuple[bytes, list[tuple[bytes, Any]]]] = deque(maxlen=8)


def remember(data: bytes, frames: list[tuple[bytes, Any]]) -> None:
    """``data`` (the concatenated ``frames``) was just packed in this process.

    Each frame comes with the message a receiver would decode from it, or None. When the
    very same bytes object reaches ``decode_frames`` (an in-process peer on the same
    topic), those messages are returned without parsing; a copy that crossed a process or
    a socket is a different object and is parsed as usual.
    """
    _packed.append((data, frames))


def decode_frames(mav: Any, data: bytes) -> list[Any]:
    """Decode concatenated, complete MAVLink frames (as our topics carry them).

    Splitting on the length byte and decoding each frame directly is several times faster
    than pymavlink's byte-wise stream parser; anything unexpected falls back to it.
    """
    for packed, frames in reversed(_packed):
        if packed is data:
            # A frame may be ``data`` itself: parse it, never look it up again.
            return [m if m is not None else _parse_frames(mav, frame)[0] for frame, m in frames]
    return _parse_frames(mav, data)


def _parse_frames(mav: Any, data: bytes) -> list[Any]:
    out: list[Any] = []
    i, n = 0, len(data)
    decode = mav.decode
    while i < n:
        magic = data[i]
        if magic == 0xFD and i + 10 <= n:
            signed = data[i + 2] & 1
            size = data[i + 1] + 12 + (13 if signed else 0)
        elif magic == 0xFE and i + 6 <= n:
            signed = 1  # MAVLink 1: pymavlink's path
            size = data[i + 1] + 8
        else:
            return out + (mav.parse_buffer(data[i:]) or [])
        frame = data[i : i + size]
        try:
            cls = None if signed else scalar_class(frame[7] | (frame[8] << 8) | (frame[9] << 16))
            out.append(
                _decode_scalar(cls, frame, frame[1])
                if cls is not None
                else decode(bytearray(frame))
            )
        except Exception:
            return out + (mav.parse_buffer(data[i:]) or [])
        i += size
    return out
