"""Reading a file's fields with errors that name the file, the field, the value and what is
allowed: the base of the readers of QGroundControl plans (``multicosim.mavlink.plan``)
and of the UAV test competition's cases
([`multicosim.px4.competition`][multicosim.px4.competition]).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from .errors import ConfigurationError

__all__ = ["FieldReader"]


class FieldReader:
    """Reads one file's decoded fields; every error names the file and where in it.

    ``MAPPING`` and ``LIST`` are what the file's format calls its mappings and lists.
    """

    MAPPING = "a mapping"
    LIST = "a list"

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, where: str, value: object, allowed: str) -> ConfigurationError:
        """The error for ``value`` at ``where`` in the file."""
        return ConfigurationError(f"{self.path}: {where}", value, allowed)

    def obj(self, where: str, value: object) -> dict[str, Any]:
        """``value``, a mapping."""
        if not isinstance(value, dict):
            raise self.fail(where, value, self.MAPPING)
        return value

    def lst(self, where: str, value: object) -> list[Any]:
        """``value``, a list."""
        if not isinstance(value, list):
            raise self.fail(where, value, self.LIST)
        return value

    def num(self, where: str, value: object, *, null: bool = False) -> float:
        """``value``, a finite number (NaN for a null where ``null`` allows one)."""
        if value is None and null:
            return math.nan
        if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
        raise self.fail(where, value, "a finite number" + (" or null" if null else ""))
