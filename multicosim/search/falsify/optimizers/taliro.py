"""psy-taliro's optimizers (``"taliro-random"``, ``"taliro-annealing"``, or one given).

psy-taliro searches the unit cube: every dimension is mapped onto [0, 1] as a Latin hypercube
maps it (``space.from_unit``), integers and choices included.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from typing import Any

from ..search import Done, Search
from ..space import Dimension, from_unit

__all__ = ["TaliroAdapter"]


class TaliroAdapter:
    """Run a psy-taliro optimizer (or the one a ``"taliro-..."`` name stands for) over ``dims``."""

    def __init__(self, optimizer: str | Any, dims: Mapping[str, Dimension]) -> None:
        self.optimizer = optimizer
        self.dims = dims

    def run(self, search: Search) -> None:
        """Let the optimizer spend the budget; stop it once the search is over."""
        optimizer = _taliro_optimizer(self.optimizer)
        from staliro.signals import Interval

        dims = self.dims
        names = list(dims)

        class Objective:
            def eval_sample(self, sample: Any) -> float:
                u = [float(v) for v in sample.values]
                return search.objective(
                    {n: from_unit(dims[n], x) for n, x in zip(names, u, strict=True)}
                )

            def eval_samples(self, samples: Any) -> list[float]:
                return [self.eval_sample(s) for s in samples]

        # Every dimension as [0, 1]: integers and choices map onto it as in a Latin hypercube.
        from ...taliro import staliro_optimizers

        params = staliro_optimizers.Optimizer.Params(
            seed=search.seed + 1,  # psy-taliro wants seeds > 0
            budget=search.budget,
            input_bounds=[Interval(0.0, 1.0) for _ in names],
        )
        with contextlib.suppress(Done):
            optimizer.optimize(Objective(), params)


def _taliro_optimizer(optimizer: Any) -> Any:
    from ...taliro import staliro_optimizers

    if optimizer == "taliro-random":
        return staliro_optimizers.UniformRandom()
    if optimizer == "taliro-annealing":
        return staliro_optimizers.DualAnnealing()
    return optimizer
