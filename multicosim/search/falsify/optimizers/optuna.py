"""optuna's samplers (``"random"``, ``"tpe"``, ``"cmaes"``, ``"gp"``), a sampler or a study."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator, Mapping
from typing import Any

from ....core.deps import require
from ..search import Done, Search
from ..space import Choice, Dimension, Integer

__all__ = ["SAMPLERS", "OptunaAdapter"]

# The optimizer names that are optuna's samplers.
SAMPLERS = ("random", "tpe", "cmaes", "gp")


class OptunaAdapter:
    """Run ``sampler`` (a name of ``SAMPLERS``, an optuna sampler or study) over ``dims``.

    A sampler given by name is seeded with the search's seed.
    """

    def __init__(self, sampler: str | Any, dims: Mapping[str, Dimension]) -> None:
        self.sampler = sampler
        self.dims = dims

    def run(self, search: Search) -> None:
        """Ask the study for samples, tell it their robustness, until the search is over."""
        sampler = self.sampler
        if isinstance(sampler, str):
            with _quiet_optuna():
                sampler = _sampler(sampler, search.seed)
        with _quiet_optuna() as optuna:
            study = sampler if isinstance(sampler, optuna.Study) else None
            if study is None:
                study = optuna.create_study(sampler=sampler, direction="minimize")
            distributions = _distributions(optuna, self.dims)
            while not search.done:
                trial = study.ask(distributions)
                try:
                    value = search.objective(_decode(self.dims, trial.params))
                except Done:
                    if search.counterexample is not None and search.lowest is not None:
                        study.tell(trial, search.lowest[0])
                    else:
                        study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    break
                study.tell(trial, value)


@contextlib.contextmanager
def _quiet_optuna() -> Iterator[Any]:
    """optuna, its logging and warnings quietened for the duration."""
    optuna = require("optuna", "search")
    previous = optuna.logging.get_verbosity()
    # Its warnings (a sampler falling back to random for a dimension) are notes, not errors.
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    try:
        with warnings.catch_warnings():
            # Experimental-feature notices and "falls back to independent sampling" notes.
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            warnings.filterwarnings("ignore", message=".*independent sampl.*")
            warnings.filterwarnings("ignore", message=".*CmaEsSampler.*")
            yield optuna
    finally:
        optuna.logging.set_verbosity(previous)


def _sampler(name: str, seed: int) -> Any:
    """optuna's sampler called ``name``, seeded (after checking what it needs is installed)."""
    samplers = require("optuna", "search").samplers
    if name == "random":
        return samplers.RandomSampler(seed=seed)
    if name == "tpe":
        return samplers.TPESampler(seed=seed, multivariate=True, n_startup_trials=10)
    if name == "cmaes":
        require("cmaes", "search")
        return samplers.CmaEsSampler(seed=seed, n_startup_trials=1)
    require("torch", "gp")
    # Few random samples before the model takes over: violations are rare, and the model
    # learns where robustness falls faster than random samples find them. Robustness is
    # modelled as noisy: controller loops make it jump a little between nearby samples.
    return samplers.GPSampler(seed=seed, n_startup_trials=5)


def _distributions(optuna: Any, dims: Mapping[str, Dimension]) -> dict[str, Any]:
    d = optuna.distributions
    out: dict[str, Any] = {}
    for name, dim in dims.items():
        if isinstance(dim, Choice):
            # Indices: the values themselves may be any objects.
            out[name] = d.CategoricalDistribution(list(range(len(dim.values))))
        elif isinstance(dim, Integer):
            out[name] = d.IntDistribution(dim.low, dim.high, log=dim.log)
        else:
            out[name] = d.FloatDistribution(dim.low, dim.high, log=dim.log)
    return out


def _decode(dims: Mapping[str, Dimension], params: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, dim in dims.items():
        value = params[name]
        if isinstance(dim, Choice):
            out[name] = dim.values[int(value)]
        elif isinstance(dim, Integer):
            out[name] = int(value)
        else:
            out[name] = float(value)
    return out
