"""Hypothesis as the optimizer (``"hypothesis"``): generation guided by the robustness, and
shrinking of the counterexample; the only one that searches a space given as a strategy."""

from __future__ import annotations

import dataclasses
import random
from collections.abc import Mapping
from typing import Any

from ....core.deps import require
from ..search import Search
from ..space import Choice, Dimension, Integer

__all__ = ["HypothesisAdapter", "HypothesisSearch"]


@dataclasses.dataclass(frozen=True)
class HypothesisSearch:
    """Hypothesis as the optimizer: ``guided`` targets the robustness, ``shrink`` shrinks the
    counterexample to a minimal one (each shrinking step is a simulation, and a confirmation
    at the higher levels when it violates; shrinking is not bounded by the budget)."""

    guided: bool = True
    shrink: bool = True


class HypothesisAdapter:
    """Run Hypothesis as ``options`` say over ``strategy``, else a strategy of ``dims``."""

    def __init__(
        self, options: HypothesisSearch, dims: Mapping[str, Dimension], strategy: Any = None
    ) -> None:
        self.options = options
        self.dims = dims
        self.strategy = strategy

    def run(self, search: Search) -> None:
        """Search with ``hypothesis.find``; the shrunk counterexample replaces the first."""
        strategy = self.strategy if self.strategy is not None else _strategy_of(self.dims)
        options = self.options
        hypothesis = require("hypothesis", "hypothesis")
        from hypothesis.errors import NoSuchExample, Unsatisfiable

        search.reuse = True

        def condition(example: Any) -> bool:
            if search.counterexample is None and search.simulations >= search.budget:
                return False  # the budget is spent: generation runs out without simulating
            value, found = search.evaluate(example)
            if options.guided and hypothesis.currently_in_test_context():
                hypothesis.target(-value)
            return found is not None

        phases = [hypothesis.Phase.generate]
        if options.guided:
            phases.append(hypothesis.Phase.target)
        if options.shrink:
            phases.append(hypothesis.Phase.shrink)
        settings = hypothesis.settings(
            max_examples=search.budget,
            phases=phases,
            database=None,
            deadline=None,
            suppress_health_check=list(hypothesis.HealthCheck),
            report_multiple_bugs=False,
        )
        try:
            # find() draws from the Random it is given: the same seed gives the same search.
            minimal = hypothesis.find(
                strategy, condition, settings=settings, random=random.Random(search.seed)
            )
        except (NoSuchExample, Unsatisfiable):
            return
        # The shrunk counterexample replaces the first one found.
        _, found = search.verdicts[repr(minimal)]
        if found is not None:
            search.counterexample = found


def _strategy_of(dims: Mapping[str, Dimension]) -> Any:
    from hypothesis import strategies as st

    parts: dict[str, Any] = {}
    for name, dim in dims.items():
        if isinstance(dim, Choice):
            parts[name] = st.sampled_from(dim.values)
        elif isinstance(dim, Integer):
            parts[name] = st.integers(dim.low, dim.high)
        else:
            parts[name] = st.floats(dim.low, dim.high)
    return st.fixed_dictionaries(parts)
