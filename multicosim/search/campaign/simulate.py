"""The one callback shape of campaigns, falsify and taliro, and the seed each call gets.

``simulate(sample, fidelity, seed)`` runs one simulation and returns a trajectory that
[`Requirement.evaluate`][multicosim.search.requirements.Requirement.evaluate] accepts.
Campaigns check it here and so do [`multicosim.search.falsify`][multicosim.search.falsify] and
[`multicosim.search.taliro`][multicosim.search.taliro], which take the same function.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import numpy as np

from ...core.errors import ConfigurationError

__all__ = ["Simulate", "check_seed", "check_simulate", "sample_seed"]

# simulate(sample, fidelity, seed) -> a trajectory Requirement.evaluate accepts
Simulate = Callable[[Any, str, int], object]


def check_simulate(simulate: object, field: str = "simulate") -> Simulate:
    """Return ``simulate`` if it can be called as ``simulate(sample, fidelity, seed)``."""
    allowed = "a function simulate(sample, fidelity, seed) returning a trajectory"
    if not callable(simulate):
        raise ConfigurationError(field, simulate, allowed)
    try:
        signature = inspect.signature(simulate)
    except (TypeError, ValueError):
        return simulate  # a builtin or extension callable: nothing to check
    try:
        signature.bind(None, "low", 0)
    except TypeError:
        raise ConfigurationError(field, simulate, f"{allowed} (it takes {signature})") from None
    return simulate


def check_seed(seed: object) -> int:
    """Return ``seed`` if it is a campaign's or a design's seed: a non-negative integer."""
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigurationError("seed", seed, "a non-negative integer")
    return seed


def sample_seed(campaign_seed: int, index: int) -> int:
    """The seed of sample ``index``: a function of the campaign seed and the index only."""
    state = np.random.SeedSequence(campaign_seed, spawn_key=(index,)).generate_state(1)
    return int(state[0])
