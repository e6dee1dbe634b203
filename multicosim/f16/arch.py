"""The ARCH-COMP falsification benchmark "F16": the GCAS autopilot must keep the F-16 airborne.

As the ARCH-COMP falsification reports define it (from AeroBench, Heidlauf et al., ARCH
2018): the F-16 flies at 540 ft/s, angle of attack 2.1215 degrees, engine power 9, from
4040 ft, in a dive whose initial roll, pitch and yaw are the inputs, within

* roll in [0.2 pi, 0.2833 pi], pitch in [-0.4 pi, -0.35 pi], yaw in [-0.375 pi, -0.125 pi];

the GCAS autopilot starts its recovery at once (roll wings level, then pull up); the
requirement is that the altitude stays above 0 for the 15 s of the flight,
``always[0,15] (altitude > 0)``, and a search may run 300 simulations:

```python
from multicosim.f16 import arch

benchmark = arch.Benchmark(aerobench="AeroBenchVVPython")
result = benchmark.falsify(levels=("low", "medium", "high"))
result.simulations, result.lowest       # what the search ran, its least robust flight
```

``altitude`` flies the same problem from another altitude (lower: a falsifiable variant).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError, check_number
from ..core.fidelity import Fidelity, check_fidelity
from ._aerobench import AeroBench
from ._messages import MAX_ALTITUDE, Flight, InitialState
from ._scenario import F16

if TYPE_CHECKING:
    from ..placement import Placement
    from ..search.falsify import FalsificationResult
    from ..search.requirements import Requirement

__all__ = ["ALTITUDE", "BUDGET", "DURATION", "INPUTS", "REQUIREMENT", "SPACE", "Benchmark"]

ALTITUDE = 4040.0
"""The initial altitude (ft)."""
DURATION = 15.0
"""The flight's length, the requirement's horizon (s)."""
BUDGET = 300
"""Simulations a search may run."""
REQUIREMENT = "always[0,15] (altitude > 0)"
"""The requirement: above the ground throughout the flight."""
INPUTS = ("roll", "pitch", "yaw")
"""The inputs, in the order a sequence sample gives them."""
SPACE: dict[str, tuple[float, float]] = {
    "roll": (0.2 * math.pi, 0.2833 * math.pi),
    "pitch": (-0.4 * math.pi, -0.35 * math.pi),
    "yaw": (-0.375 * math.pi, -0.125 * math.pi),
}
"""The initial roll, pitch and yaw (rad) a search chooses from."""


class Benchmark:
    """F16 as a falsification problem: ``benchmark(sample, fidelity, seed)`` flies a sample.

    ``aerobench`` is where AeroBench is (an [`AeroBench`][multicosim.f16.AeroBench], a path, or
    None for ``MCS_AEROBENCH_DIR``); ``altitude`` the initial altitude (ARCH-COMP's 4040 ft
    by default); ``placement`` where each flight runs (None: the fidelity's default).
    Everything is checked here.

    Raises:
        ConfigurationError: naming the field with an invalid value.
    """

    def __init__(
        self,
        aerobench: AeroBench | str | os.PathLike[str] | None = None,
        *,
        altitude: float = ALTITUDE,
        placement: str | Placement | None = None,
    ) -> None:
        self.aerobench = aerobench if isinstance(aerobench, AeroBench) else AeroBench(aerobench)
        self.altitude = check_number("altitude", altitude, 0.0, MAX_ALTITUDE, open_lo=True)
        self.placement = placement
        self.space: dict[str, tuple[float, float]] = dict(SPACE)
        """The inputs and their ranges (rad)."""
        self.formula = REQUIREMENT

    @property
    def requirement(self) -> Requirement:
        """The requirement as an STL [`Requirement`][multicosim.search.requirements.Requirement]."""
        from ..search.requirements import Requirement

        return Requirement(self.formula)

    def initial(self, sample: Mapping[str, float] | Sequence[float]) -> InitialState:
        """The initial state of ``sample`` (roll, pitch, yaw: a mapping, or in that order).

        Raises:
            ConfigurationError: naming the input that is missing or outside its range.
        """
        values = _values(sample)
        for name, value in values.items():
            low, high = self.space[name]
            # An optimizer's sample may land a rounding error past a bound: that is in.
            slack = 1e-9 * (high - low)
            check_number(name, value, low - slack, high + slack)
        return InitialState(altitude=self.altitude, **values)

    def scenario(
        self, sample: Mapping[str, float] | Sequence[float], fidelity: Fidelity, seed: int = 0
    ) -> F16:
        """The F-16 scenario that flies ``sample`` at ``fidelity``."""
        return F16(
            fidelity=check_fidelity(fidelity),
            placement=self.placement,
            seed=seed,
            aerobench=self.aerobench,
            initial=self.initial(sample),
            duration=DURATION,
        )

    def __call__(
        self, sample: Mapping[str, float] | Sequence[float], fidelity: str, seed: int
    ) -> Flight:
        """Fly ``sample`` at ``fidelity``: the flight (what the requirement is evaluated on)."""
        return self.scenario(sample, check_fidelity(fidelity), seed).fly()

    def falsify(
        self,
        *,
        levels: Sequence[str] | str = ("low", "medium", "high"),
        budget: int = BUDGET,
        optimizer: str | Any = None,
        seed: int = 0,
        trace_dir: str | Path | None = None,
        progress: bool | None = None,
    ) -> FalsificationResult:
        """Search the inputs for a flight into the ground: searched at ``levels[0]``, each
        violation confirmed at the levels after it (see
        [`multicosim.search.falsify.falsify`][multicosim.search.falsify.falsify]).
        """
        from ..search.falsify import falsify

        return falsify(
            self,
            self.formula,
            self.space,
            optimizer=optimizer,
            budget=budget,
            seed=seed,
            levels=levels,
            trace_dir=trace_dir,
            progress=progress,
        )

    def __repr__(self) -> str:
        return f"Benchmark(altitude={self.altitude:g}, aerobench={str(self.aerobench)!r})"


def _values(sample: object) -> dict[str, float]:
    allowed = f"a mapping of {', '.join(INPUTS)} to radians, or the three in that order"
    if isinstance(sample, Mapping):
        missing = [name for name in INPUTS if name not in sample]
        if missing:
            raise ConfigurationError(missing[0], None, allowed)
        return {name: sample[name] for name in INPUTS}
    if isinstance(sample, str) or not isinstance(sample, Sequence) or len(sample) != 3:
        raise ConfigurationError("sample", sample, allowed)
    return dict(zip(INPUTS, sample, strict=True))
