"""Any optimizer object with ``ask()`` and ``tell(asked, robustness)``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

from ....core.errors import ConfigurationError
from ..search import Done, Search
from ..space import Dimension

__all__ = ["AskTell", "AskTellAdapter"]


@runtime_checkable
class AskTell(Protocol):
    """Any optimizer with an ask/tell interface.

    ``ask()`` returns a sample: a mapping of dimension name to value, or the values in the
    space's order. ``tell(asked, robustness)`` gets back what ``ask`` returned, scored (the
    optimizer should minimize it).
    """

    def ask(self) -> Any: ...
    def tell(self, asked: Any, robustness: float) -> Any: ...


class AskTellAdapter:
    """Run an [`AskTell`][multicosim.search.falsify.optimizers.asktell.AskTell] optimizer over
    ``dims``."""

    def __init__(self, optimizer: AskTell, dims: Mapping[str, Dimension]) -> None:
        self.optimizer = optimizer
        self.dims = dims

    def run(self, search: Search) -> None:
        """Ask for a sample, tell its robustness, until the search is over."""
        optimizer = self.optimizer
        names = list(self.dims)
        while not search.done:
            asked = optimizer.ask()
            if isinstance(asked, Mapping):
                sample = dict(asked)
            elif isinstance(asked, Sequence) and len(asked) == len(names):
                sample = dict(zip(names, asked, strict=True))
            else:
                raise ConfigurationError(
                    "optimizer.ask()", asked, f"a mapping or {len(names)} values in order {names}"
                )
            missing = [n for n in names if n not in sample]
            if missing:
                raise ConfigurationError("optimizer.ask()", asked, f"a value for each of {names}")
            try:
                value = search.objective(sample)
            except Done:
                if search.counterexample is not None and search.lowest is not None:
                    optimizer.tell(asked, search.lowest[0])
                return
            optimizer.tell(asked, value)
