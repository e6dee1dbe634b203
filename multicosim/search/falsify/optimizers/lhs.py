"""A Latin hypercube (``"lhs"``): ``budget`` samples spread over the space, none learnt from."""

from __future__ import annotations

from collections.abc import Mapping

from ....core.deps import require
from ..search import Done, Search
from ..space import Dimension, from_unit

__all__ = ["LatinHypercubeAdapter"]


class LatinHypercubeAdapter:
    """Simulate the samples of a Latin hypercube over ``dims`` (seeded by the search's seed)."""

    def __init__(self, dims: Mapping[str, Dimension]) -> None:
        self.dims = dims

    def run(self, search: Search) -> None:
        """Simulate the design's samples in turn until the search is over."""
        qmc = require("scipy.stats.qmc", "search")
        design = qmc.LatinHypercube(d=len(self.dims), rng=search.seed).random(search.budget)
        names = list(self.dims)
        for row in design:
            sample = {
                name: from_unit(self.dims[name], float(u))
                for name, u in zip(names, row, strict=True)
            }
            try:
                search.objective(sample)
            except Done:
                return
