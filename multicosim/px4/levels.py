"""Real PX4 as a rung of a falsifying search: search cheaply, confirm on the real firmware.

```python
import multicosim.px4 as px4
from multicosim.search.falsify import falsify

def simulate(sample, fidelity, seed, firmware=None):
    simulator = px4.PX4(fidelity=fidelity, seed=seed, firmware=firmware)
    ...                                       # injectors from the sample, fly, trajectory

real = px4.sitl_level(simulate, px4.SITL(binary="../shared/px4-sitl/bin/px4"))
falsify(simulate, requirement, space, levels=("low", "medium", real))
```

The search runs ``simulate`` with the built-in autopilot; a violation that medium fidelity
confirms is flown once more with real PX4 SITL on the same MuJoCo world. Real PX4 runs its
modules as threads, so a run is close to, not a replay of, another with the same seed: a
violation there says the real firmware fails the same way, with a margin (its robustness)
that may vary a little from run to run.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError
from ..core.fidelity import FIRMWARE_FIDELITIES
from .sitl import SITL

if TYPE_CHECKING:
    from ..core.fidelity import Fidelity
    from ..search.falsify import Level

__all__ = ["SITL_LEVEL", "sitl_level"]

SITL_LEVEL = "px4-sitl"
"""The default name of the real-PX4 level (in results, statistics and trace directories)."""


class _OnSITL:
    """``simulate(sample, fidelity, seed, firmware=sitl)`` at the real-PX4 fidelity."""

    def __init__(self, simulate: Callable[..., Any], firmware: SITL, fidelity: str) -> None:
        self.simulate = simulate
        self.firmware = firmware
        self.fidelity = fidelity

    def __call__(self, sample: Any, fidelity: str, seed: int) -> Any:
        # ``fidelity`` is the level's name here; real PX4 flies at its own fidelity.
        return self.simulate(sample, self.fidelity, seed, firmware=self.firmware)

    def __repr__(self) -> str:
        return f"{getattr(self.simulate, '__name__', self.simulate)!s} on {self.firmware!r}"


def sitl_level(
    simulate: Callable[..., Any],
    firmware: SITL,
    *,
    name: str = SITL_LEVEL,
    fidelity: Fidelity = "medium",
) -> Level:
    """A [`multicosim.search.falsify.Level`][multicosim.search.falsify.Level] that runs a sample on
    real PX4 SITL.

    ``simulate(sample, fidelity, seed, firmware=None)`` is the search's own function with a
    ``firmware`` keyword that it passes to ``px4.PX4(..., firmware=firmware)``; this level
    calls it with ``firmware`` and ``fidelity`` (``"medium"``: PX4 as a local process;
    ``"high"``: the finer world, PX4 in a container where ``simulate`` picks
    ``backend="docker"``).
    """
    from ..search.falsify import Level

    if not isinstance(firmware, SITL):
        raise ConfigurationError("firmware", firmware, "a px4.SITL(binary=...) or SITL(image=...)")
    if fidelity not in FIRMWARE_FIDELITIES:
        raise ConfigurationError(
            "fidelity", fidelity, f"one of {FIRMWARE_FIDELITIES}: real PX4 flies the MuJoCo world"
        )
    allowed = "a function simulate(sample, fidelity, seed, firmware=None)"
    if not callable(simulate):
        raise ConfigurationError("simulate", simulate, allowed)
    try:
        signature = inspect.signature(simulate)
    except (TypeError, ValueError):
        signature = None  # a builtin or extension callable: nothing to check
    if signature is not None:
        try:
            signature.bind(None, fidelity, 0, firmware=firmware)
        except TypeError:
            raise ConfigurationError(
                "simulate", simulate, f"{allowed} (it takes {signature})"
            ) from None
    return Level(name, _OnSITL(simulate, firmware, fidelity))
