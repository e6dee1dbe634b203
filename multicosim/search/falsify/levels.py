"""The fidelity ladder of a falsification: the search level first, then each confirming one."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from ...core.errors import ConfigurationError
from ...core.fidelity import FIDELITIES
from ..campaign.simulate import Simulate, check_simulate

__all__ = ["Level", "levels_of"]


@dataclasses.dataclass(frozen=True)
class Level:
    """A rung of the fidelity ladder: ``name``, and how to simulate there.

    ``simulate`` (the same shape as falsify's: ``(sample, fidelity, seed)``, called with
    ``fidelity=name``) runs a sample at this level; None uses the function given to
    [`falsify`][multicosim.search.falsify.falsify]. A level of its own simulate function plugs in
    what falsify knows nothing of (real firmware in the loop, hardware, another simulator).
    """

    name: str
    simulate: Simulate | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigurationError("level name", self.name, "a non-empty string")
        if self.simulate is not None:
            check_simulate(self.simulate, f"levels[{self.name!r}].simulate")


def levels_of(levels: Sequence[str | Level | Simulate] | str) -> tuple[Level, ...]:
    """The levels that falsify's ``levels`` argument names, checked: distinct, at least one."""
    given: Sequence[Any] = (levels,) if isinstance(levels, str | Level) else levels
    allowed = (
        f"distinct levels, search level first: names from {FIDELITIES}, Level objects "
        "or simulate functions"
    )
    out: list[Level] = []
    if not isinstance(given, Sequence) or not given:
        raise ConfigurationError("levels", levels, allowed)
    for item in given:
        if isinstance(item, Level):
            out.append(item)
        elif isinstance(item, str):
            if item not in FIDELITIES:
                raise ConfigurationError("levels", levels, allowed)
            out.append(Level(item))
        elif callable(item):
            name = getattr(item, "name", None) or getattr(item, "__name__", None)
            out.append(Level(str(name or repr(item)), item))
        else:
            raise ConfigurationError("levels", levels, allowed)
    names = [level.name for level in out]
    if len(set(names)) != len(names):
        raise ConfigurationError("levels", names, allowed)
    return tuple(out)
