"""Parameter files: the vehicle parameters a test sets before the vehicle arms.

Three formats, told apart by their first line that is not a comment (``#``) or blank:

* PX4's shell: ``param set NAME VALUE`` (as in ``rcS`` or an airframe file);
* QGroundControl's ``.params``: tab-separated vehicle id, component id, name, value and
  MAVLink type (``MAV_PARAM_TYPE``: 1-8 integers, 9 ``REAL32``);
* CSV: ``name,value`` (a ``name,value`` header line is allowed).

Names are PX4's and ArduPilot's (upper case, at most 16 characters); values finite numbers.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from ..core.errors import ConfigurationError

__all__ = ["PARAM_NAME", "read_params"]

PARAM_NAME = re.compile(r"^[A-Z][A-Z0-9_]{0,15}$")
"""What a PX4 or ArduPilot parameter name looks like."""

_INTEGER_TYPES = range(1, 9)  # MAV_PARAM_TYPE_UINT8 .. INT64
_REAL_TYPES = (9, 10)  # REAL32, REAL64


def _px4(fields: list[str]) -> tuple[str, str] | None:
    words = " ".join(fields).split()
    if len(words) == 4 and words[:2] == ["param", "set"]:
        return words[2], words[3]
    return None


def _qgc(fields: list[str]) -> tuple[str, str] | None:
    if len(fields) == 5 and fields[0].strip().isdigit() and fields[1].strip().isdigit():
        return fields[2].strip(), fields[3].strip()
    return None


def _csv(fields: list[str]) -> tuple[str, str] | None:
    if len(fields) == 2:
        return fields[0].strip(), fields[1].strip()
    return None


_FORMATS = {
    "param set": (" ", _px4),
    "QGroundControl .params": ("\t", _qgc),
    "name,value CSV": (",", _csv),
}


def _format(line: str) -> str | None:
    if line.split()[:2] == ["param", "set"]:
        return "param set"
    if line.count("\t") == 4:
        return "QGroundControl .params"
    if line.count(",") == 1:
        return "name,value CSV"
    return None


def read_params(path: str | Path) -> dict[str, float]:
    """The parameters a file sets, by name, in file order (a later line wins).

    ConfigurationError names the file, the line and what is wrong with it: an unknown
    format, a line of another format, a bad name, a value that is not a finite number or
    not an integer where QGroundControl's type says it is one.
    """
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigurationError(
            "params", str(path), f"a readable parameter file ({exc})"
        ) from None
    params: dict[str, float] = {}
    kind: str | None = None
    for number, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        where = f"{path}: line {number}"
        if kind is None:
            kind = _format(line)
            if kind is None:
                raise ConfigurationError(
                    where,
                    line,
                    "a parameter file: 'param set NAME VALUE' lines, QGroundControl's .params "
                    "(vehicle, component, name, value, type; tab-separated) or 'name,value' CSV",
                )
            if kind == "name,value CSV" and line.replace(" ", "").lower() == "name,value":
                continue
        separator, parse = _FORMATS[kind]
        entry = parse(raw.split(separator) if separator != " " else [line])
        if entry is None:
            raise ConfigurationError(where, line, f"a line of the file's format ({kind})")
        name, text = entry
        if not PARAM_NAME.match(name):
            raise ConfigurationError(
                where, name, "a parameter name (upper case, at most 16 characters)"
            )
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise ConfigurationError(f"{where}: {name}", text, "a finite number")
        if kind == "QGroundControl .params":
            ptype = raw.split("\t")[4].strip()
            if not ptype.isdigit() or int(ptype) not in (*_INTEGER_TYPES, *_REAL_TYPES):
                raise ConfigurationError(
                    f"{where}: {name} type", ptype, "a MAV_PARAM_TYPE, 1 to 10"
                )
            if int(ptype) in _INTEGER_TYPES and not value.is_integer():
                raise ConfigurationError(
                    f"{where}: {name}", text, f"an integer (its type is {ptype})"
                )
        params[name] = value
    return params
