"""The optimizers falsify drives: one adapter module per kind, behind ``protocol``.

* ``optuna``: optuna's samplers by name (``"random"``, ``"tpe"``, ``"cmaes"``, ``"gp"``),
  or an optuna sampler or study;
* ``lhs``: a Latin hypercube (``"lhs"``);
* [`taliro`][multicosim.search.taliro]: psy-taliro's optimizers (``"taliro-random"``,
  ``"taliro-annealing"``, or one given);
* ``hypothesis``: Hypothesis (``"hypothesis"``,
  [`HypothesisSearch`][multicosim.search.falsify.optimizers.HypothesisSearch]);
* ``asktell``: any object with ``ask()`` and ``tell(asked, robustness)``.

``adapter_for`` picks the adapter of what the user passed as ``optimizer``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ....core.errors import ConfigurationError
from ..space import Dimension
from .asktell import AskTell, AskTellAdapter
from .hypothesis import HypothesisAdapter, HypothesisSearch
from .lhs import LatinHypercubeAdapter
from .optuna import SAMPLERS, OptunaAdapter
from .protocol import Adapter
from .taliro import TaliroAdapter

__all__ = [
    "DEFAULT_OPTIMIZER",
    "FALLBACK_OPTIMIZER",
    "OPTIMIZERS",
    "Adapter",
    "AskTell",
    "HypothesisSearch",
    "adapter_for",
    "check_name",
    "default_optimizer",
    "name_of",
]

OPTIMIZERS = (
    "random",
    "lhs",
    "tpe",
    "cmaes",
    "gp",
    "hypothesis",
    "taliro-random",
    "taliro-annealing",
)
# The optimizer that needed the fewest simulations on the shipped benchmark (bench/); it
# needs torch (the ``gp`` extra). Without torch the default is the next best, which does not.
DEFAULT_OPTIMIZER = "gp"
FALLBACK_OPTIMIZER = "tpe"

_ALLOWED = f"one of {OPTIMIZERS}, an optuna sampler, a psy-taliro optimizer or an ask/tell object"


def default_optimizer() -> str:
    """``DEFAULT_OPTIMIZER`` where torch is installed, else ``FALLBACK_OPTIMIZER``."""
    import importlib.util

    return DEFAULT_OPTIMIZER if importlib.util.find_spec("torch") else FALLBACK_OPTIMIZER


def check_name(optimizer: Any) -> None:
    """ConfigurationError if ``optimizer`` is a name but not one of
    [`OPTIMIZERS`][multicosim.search.falsify.optimizers.OPTIMIZERS]."""
    if isinstance(optimizer, str) and optimizer not in OPTIMIZERS:
        raise ConfigurationError("optimizer", optimizer, _ALLOWED)


def name_of(optimizer: Any) -> str:
    """How a result and the progress bar name ``optimizer``."""
    if isinstance(optimizer, str):
        return optimizer
    if isinstance(optimizer, HypothesisSearch):
        return "hypothesis" + ("" if optimizer.guided else " (unguided)")
    return type(optimizer).__name__


def adapter_for(optimizer: Any, dims: Mapping[str, Dimension], strategy: Any = None) -> Adapter:
    """The adapter that runs ``optimizer`` over ``dims`` (or, for Hypothesis, ``strategy``
    where the space is one); ConfigurationError for what none can run."""
    if isinstance(optimizer, HypothesisSearch):
        return HypothesisAdapter(optimizer, dims, strategy)
    if isinstance(optimizer, str):
        if optimizer in SAMPLERS:
            return OptunaAdapter(optimizer, dims)
        if optimizer == "lhs":
            return LatinHypercubeAdapter(dims)
        if optimizer.startswith("taliro-"):
            return TaliroAdapter(optimizer, dims)
        raise ConfigurationError("optimizer", optimizer, _ALLOWED)
    module = type(optimizer).__module__
    if module.startswith("optuna"):
        return OptunaAdapter(optimizer, dims)
    if module.startswith("staliro"):
        return TaliroAdapter(optimizer, dims)
    if isinstance(optimizer, AskTell):
        return AskTellAdapter(optimizer, dims)
    raise ConfigurationError("optimizer", optimizer, _ALLOWED)
