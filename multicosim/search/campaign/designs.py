"""Designs of experiments: the samples a campaign evaluates.

A design is a list of samples, the same list for the same seed: uniform draws from a box
([`random_design`][multicosim.search.campaign.designs.random_design]), a Latin hypercube over it
([`latin_hypercube`][multicosim.search.campaign.designs.latin_hypercube]) or the examples of a
Hypothesis strategy ([`from_strategy`][multicosim.search.campaign.designs.from_strategy]).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...core.deps import require
from ...core.errors import ConfigurationError
from .simulate import check_seed

__all__ = ["from_strategy", "latin_hypercube", "random_design"]


def _check_count(n: object) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigurationError("n", n, "a positive number of samples")
    return n


def _check_ranges(ranges: Mapping[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    if not isinstance(ranges, Mapping) or not ranges:
        raise ConfigurationError("ranges", ranges, "a mapping of at least one name to (low, high)")
    out: dict[str, tuple[float, float]] = {}
    for name, bounds in ranges.items():
        ok = (
            isinstance(bounds, tuple | list)
            and len(bounds) == 2
            and all(isinstance(b, int | float) and not isinstance(b, bool) for b in bounds)
            and all(math.isfinite(b) for b in bounds)
            and bounds[0] < bounds[1]
        )
        if not ok:
            raise ConfigurationError(
                f"ranges[{name!r}]", bounds, "(low, high) with finite low < high"
            )
        out[str(name)] = (float(bounds[0]), float(bounds[1]))
    return out


def random_design(
    ranges: Mapping[str, tuple[float, float]], n: int, *, seed: int = 0
) -> list[dict[str, float]]:
    """``n`` samples drawn uniformly from the box ``ranges`` (name -> (low, high))."""
    box, n, seed = _check_ranges(ranges), _check_count(n), check_seed(seed)
    rng = np.random.default_rng(seed)
    columns = {name: rng.uniform(lo, hi, n) for name, (lo, hi) in box.items()}
    return [{name: float(col[i]) for name, col in columns.items()} for i in range(n)]


def latin_hypercube(
    ranges: Mapping[str, tuple[float, float]], n: int, *, seed: int = 0
) -> list[dict[str, float]]:
    """``n`` samples of a Latin hypercube over ``ranges``: each range cut in ``n`` strata, one
    sample in each stratum of every input."""
    box, n, seed = _check_ranges(ranges), _check_count(n), check_seed(seed)
    rng = np.random.default_rng(seed)
    columns = {}
    for name, (lo, hi) in box.items():
        strata = (rng.permutation(n) + rng.random(n)) / n
        columns[name] = lo + strata * (hi - lo)
    return [{name: float(col[i]) for name, col in columns.items()} for i in range(n)]


def from_strategy(strategy: Any, n: int, *, seed: int = 0) -> list[Any]:
    """Up to ``n`` examples of a Hypothesis strategy, the same ones for the same seed.

    Fewer come back when the strategy has fewer distinct examples.
    """
    n, seed = _check_count(n), check_seed(seed)
    require("hypothesis", "hypothesis")
    import hypothesis

    if not isinstance(strategy, hypothesis.strategies.SearchStrategy):
        raise ConfigurationError("strategy", strategy, "a Hypothesis strategy")
    drawn: list[Any] = []

    # A throwaway @given test is Hypothesis's seedable way to draw examples (.example() is not).
    @hypothesis.settings(
        max_examples=n,
        database=None,
        deadline=None,
        phases=[hypothesis.Phase.generate],
        suppress_health_check=list(hypothesis.HealthCheck),
    )
    @hypothesis.seed(seed)
    @hypothesis.given(strategy)
    def collect(example: Any) -> None:
        drawn.append(example)

    collect()
    return drawn[:n]
