"""MAVLink telemetry logs (``.tlog``): what QGroundControl, MAVExplorer and pymavlink replay.

A ``.tlog`` is a sequence of records, each an 8-byte big-endian timestamp (microseconds)
followed by one MAVLink frame. Timestamps here are simulated time.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from pathlib import Path

from ..core.errors import TraceError
from ..core.files import replacing

__all__ = ["split_frames", "write_tlog"]

_STAMP = struct.Struct(">Q")


def split_frames(data: bytes) -> Iterator[bytes]:
    """The MAVLink 1/2 frames in ``data`` (concatenated, complete frames); stops at garbage."""
    i, n = 0, len(data)
    while i < n:
        magic = data[i]
        if magic == 0xFD and i + 3 <= n:
            size = data[i + 1] + 12 + (13 if data[i + 2] & 1 else 0)
        elif magic == 0xFE and i + 2 <= n:
            size = data[i + 1] + 8
        else:
            return
        if i + size > n:
            return
        yield data[i : i + size]
        i += size


def write_tlog(path: Path, frames: Iterable[tuple[int, bytes]]) -> Path:
    """Write ``(time_ns, frames)`` pairs, in time order, as a ``.tlog`` at ``path``."""
    try:
        with replacing(path) as temporary, open(temporary, "wb") as stream:
            for time_ns, data in frames:
                stamp = _STAMP.pack(time_ns // 1000)
                for frame in split_frames(data):
                    stream.write(stamp)
                    stream.write(frame)
    except OSError as exc:
        raise TraceError(f"could not write the MAVLink log {str(path)!r}: {exc}") from exc
    return path
