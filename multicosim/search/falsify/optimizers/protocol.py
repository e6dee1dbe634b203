"""What falsify needs of an optimizer: the ``Adapter`` protocol.

An adapter wraps one kind of optimizer (optuna, a Latin hypercube, psy-taliro, Hypothesis,
any ask/tell object) so that it proposes samples to ``Search.objective`` and learns
the robustness it returns, until the search is over (``Search.done``, or ``Done``
raised by the objective). Building an adapter imports nothing heavy; ``run`` imports what
the optimizer needs.
"""

from __future__ import annotations

from typing import Protocol

from ..search import Search

__all__ = ["Adapter"]


class Adapter(Protocol):
    """One optimizer, made to minimize a search's objective."""

    def run(self, search: Search) -> None:
        """Propose samples to ``search.objective`` until the search is over."""
        ...
