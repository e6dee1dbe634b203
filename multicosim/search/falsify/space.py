"""The space a falsification searches: real, integer and choice dimensions, by name.

A space maps names to dimensions: ``(low, high)`` or [`Real`][multicosim.search.falsify.space.Real]
for a real interval, [`Integer`][multicosim.search.falsify.space.Integer],
[`Choice`][multicosim.search.falsify.space.Choice]; a
[`FIDELITY`][multicosim.search.falsify.space.FIDELITY] dimension makes the fidelity a search
variable. ``from_unit`` maps [0, 1] onto a dimension, for optimizers that search the unit cube (a
Latin hypercube, psy-taliro).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from ...core.errors import ConfigurationError

__all__ = [
    "FIDELITY",
    "Choice",
    "Dimension",
    "Integer",
    "Real",
    "dimensions",
    "from_unit",
    "is_strategy",
]

# The name of the dimension that makes the fidelity a search variable.
FIDELITY = "fidelity"


def _number(field: str, value: object, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigurationError(field, value, allowed)
    return float(value)


@dataclasses.dataclass(frozen=True)
class Real:
    """Real values in ``[low, high]`` (``log``: uniform in the logarithm, for scales)."""

    low: float
    high: float
    log: bool = False

    def __post_init__(self) -> None:
        allowed = "finite low < high" + (" with low > 0 (log scale)" if self.log else "")
        lo = _number("low", self.low, allowed)
        hi = _number("high", self.high, allowed)
        if not lo < hi or (self.log and lo <= 0):
            raise ConfigurationError("(low, high)", (self.low, self.high), allowed)


@dataclasses.dataclass(frozen=True)
class Integer:
    """Whole numbers from ``low`` to ``high``, both included."""

    low: int
    high: int
    log: bool = False

    def __post_init__(self) -> None:
        allowed = "integers low <= high" + (" with low >= 1 (log scale)" if self.log else "")
        for value in (self.low, self.high):
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigurationError("(low, high)", (self.low, self.high), allowed)
        if self.low > self.high or (self.log and self.low < 1):
            raise ConfigurationError("(low, high)", (self.low, self.high), allowed)


class Choice:
    """One of ``values`` (any objects: names, configurations, fidelity levels)."""

    def __init__(self, *values: Any) -> None:
        if not values:
            raise ConfigurationError("values", values, "at least one value to choose from")
        self.values: tuple[Any, ...] = values

    def __repr__(self) -> str:
        return f"Choice({', '.join(map(repr, self.values))})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Choice) and self.values == other.values

    def __hash__(self) -> int:
        return hash(self.values)


# One dimension of a space, as dimensions() reads it.
Dimension = Real | Integer | Choice


def dimensions(space: Mapping[str, Any]) -> dict[str, Dimension]:
    """The dimensions of ``space``, a ``(low, high)`` pair read as
    [`Real`][multicosim.search.falsify.space.Real]."""
    if not space:
        raise ConfigurationError("space", space, "at least one dimension")
    out: dict[str, Dimension] = {}
    for name, dim in space.items():
        if not isinstance(name, str) or not name:
            raise ConfigurationError("space", name, "dimension names that are non-empty strings")
        if isinstance(dim, Real | Integer | Choice):
            out[name] = dim
        elif isinstance(dim, tuple | list) and len(dim) == 2:
            try:
                out[name] = Real(*dim)
            except ConfigurationError:
                raise ConfigurationError(
                    f"space[{name!r}]", dim, "(low, high) with finite low < high"
                ) from None
        else:
            raise ConfigurationError(
                f"space[{name!r}]", dim, "(low, high), Real(...), Integer(low, high) or Choice(...)"
            )
    return out


def from_unit(dim: Dimension, u: float) -> Any:
    """The value at ``u`` in [0, 1] along ``dim`` (what a Latin hypercube or psy-taliro draws)."""
    u = min(max(u, 0.0), 1.0)
    if isinstance(dim, Choice):
        return dim.values[min(int(u * len(dim.values)), len(dim.values) - 1)]
    if isinstance(dim, Integer):
        if dim.log:
            lo, hi = math.log(dim.low), math.log(dim.high + 1)
            return min(math.floor(math.exp(lo + u * (hi - lo))), dim.high)
        return min(math.floor(dim.low + u * (dim.high + 1 - dim.low)), dim.high)
    if dim.log:
        return math.exp(math.log(dim.low) + u * (math.log(dim.high) - math.log(dim.low)))
    return dim.low + u * (dim.high - dim.low)


def is_strategy(space: object) -> bool:
    """Whether ``space`` is a Hypothesis strategy (False where Hypothesis is not installed)."""
    try:
        from hypothesis.strategies import SearchStrategy
    except ImportError:
        return False
    return isinstance(space, SearchStrategy)
