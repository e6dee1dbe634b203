"""The parameters our autopilot exposes over the MAVLink parameter protocol: PX4's own.

The table (every name PX4 v1.15.4 SITL reports, its MAVLink type, the value it has when PX4
flies our world, and the range PX4's metadata gives) is the one recorded from real PX4 by
``scripts/record_px4.py`` (``conformance``). The autopilot acts on the ones its
commander, navigator and controller read; the others are stored and echoed as PX4 does.
"""

from __future__ import annotations

import math
import struct
from functools import cache
from typing import NamedTuple

__all__ = [
    "PARAM_INT32",
    "PARAM_REAL32",
    "Param",
    "Params",
    "decode_value",
    "encode_value",
    "table",
]

PARAM_UINT8, PARAM_INT8, PARAM_UINT16, PARAM_INT16 = 1, 2, 3, 4
PARAM_UINT32, PARAM_INT32, PARAM_REAL32 = 5, 6, 9
_INT_FORMATS = {1: "<B", 2: "<b", 3: "<H", 4: "<h", 5: "<I", 6: "<i"}


class Param(NamedTuple):
    """One parameter: MAVLink type, value in our world, and PX4's range (None: unbounded)."""

    type: int
    value: float
    min: float | None
    max: float | None


@cache
def table() -> dict[str, Param]:
    """PX4's parameters by name (in PX4's index order: sorted by name)."""
    from ..conformance import load

    out = {}
    for name, p in load()["params"].items():
        out[name] = Param(int(p["type"]), float(p["value"]), p.get("min"), p.get("max"))
    return dict(sorted(out.items()))


def encode_value(value: float, ptype: int) -> float:
    """``value`` as PARAM_VALUE carries it: integers bytewise in the float, as PX4 sends."""
    fmt = _INT_FORMATS.get(ptype)
    if fmt is None:
        return float(value)
    raw = struct.pack(fmt, int(value)).ljust(4, b"\0")
    return float(struct.unpack("<f", raw)[0])


def decode_value(wire: float, ptype: int) -> float:
    """The value a PARAM_SET of type ``ptype`` means (bytewise integers, as PX4 reads them)."""
    fmt = _INT_FORMATS.get(ptype)
    if fmt is None:
        return float(wire)
    raw = struct.pack("<f", wire)
    return float(struct.unpack(fmt, raw[: struct.calcsize(fmt)])[0])


class Params(dict[str, float]):
    """Parameter values by name, PX4's in our world unless set; range-checked configuration."""

    def __init__(self, values: dict[str, float] | None = None) -> None:
        spec = table()
        super().__init__((name, p.value) for name, p in spec.items())
        for name, value in (values or {}).items():
            if not self.set(name, value):
                from ...core.errors import ConfigurationError

                p = spec.get(name)
                if p is None:
                    raise ConfigurationError(f"params[{name!r}]", value, "a PX4 parameter name")
                lo = "-inf" if p.min is None else f"{p.min:g}"
                hi = "inf" if p.max is None else f"{p.max:g}"
                raise ConfigurationError(f"params[{name!r}]", value, f"a value in [{lo}, {hi}]")

    def set(self, name: str, value: float) -> bool:
        """Set ``name`` if it exists and ``value`` is within PX4's range; whether it was set."""
        p = table().get(name)
        if p is None or not math.isfinite(value):
            return False
        if (p.min is not None and value < p.min) or (p.max is not None and value > p.max):
            return False
        self[name] = float(value)
        return True

    def assign(self, name: str, value: float) -> bool:
        """Set ``name`` to any finite ``value`` (as a PARAM_SET does); whether it was set."""
        if name not in self or not math.isfinite(value):
            return False
        self[name] = float(value)
        return True

    def type_of(self, name: str) -> int:
        """The MAVLink type of ``name``."""
        return table()[name].type

    @property
    def names(self) -> list[str]:
        """Parameter names in index order."""
        return list(table())
