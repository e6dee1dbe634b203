"""falsify(): check the arguments, run the optimizer's adapter over a search, report.

The search itself is ``search.Search``; the optimizers are adapted in
``optimizers``; what comes back is described in ``results``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ...core.errors import ConfigurationError
from ..campaign.simulate import Simulate, check_simulate
from ..progress import ProgressBar, wanted
from ..requirements import Requirement
from .levels import Level, levels_of
from .optimizers import HypothesisSearch, adapter_for, check_name, default_optimizer, name_of
from .results import FalsificationResult
from .search import Search
from .space import FIDELITY, Choice, dimensions, is_strategy

__all__ = ["falsify"]


def _check_int(field: str, value: object, low: int, allowed: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ConfigurationError(field, value, allowed)
    return value


def falsify(
    run: Simulate,
    requirement: Requirement | str,
    space: Mapping[str, Any] | Any,
    *,
    optimizer: str | Any = None,
    budget: int = 100,
    seed: int = 0,
    levels: Sequence[str | Level | Simulate] | str = ("low", "medium"),
    trace_dir: str | Path | None = None,
    progress: bool | None = None,
) -> FalsificationResult:
    """Search ``space`` for a violation of ``requirement``; confirm it at every level.

    ``run(sample, fidelity, seed)`` runs one simulation and returns its trajectory (anything
    ``Requirement.evaluate`` accepts). See [`multicosim.search.falsify`][multicosim.search.falsify]
    for ``space``, ``optimizer`` and ``levels``. With ``trace_dir``, every violating simulation
    leaves its MCAP trace and plot under ``trace_dir/sample-NNNNN/LEVEL``. ``progress`` shows a bar
    on stderr (None: when stderr is a terminal).
    """
    run = check_simulate(run, "run")
    if optimizer is None:
        optimizer = default_optimizer()
    lv = levels_of(levels)
    budget = _check_int("budget", budget, 1, "a positive number of simulations")
    seed = _check_int("seed", seed, 0, "a non-negative integer")
    req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)
    strategy_space = is_strategy(space)
    if not strategy_space and not isinstance(space, Mapping):
        raise ConfigurationError(
            "space", space, "a mapping of name to (low, high), Integer or Choice, or a strategy"
        )
    dims = {} if strategy_space else dimensions(space)
    fidelity_dim = FIDELITY in dims
    if fidelity_dim:
        dim = dims[FIDELITY]
        names = [level.name for level in lv]
        if not isinstance(dim, Choice) or any(v not in names for v in dim.values):
            raise ConfigurationError(
                f"space[{FIDELITY!r}]", dim, f"Choice(...) of level names from {names}"
            )
    check_name(optimizer)
    if optimizer == "hypothesis":
        optimizer = HypothesisSearch()
    if strategy_space and not isinstance(optimizer, HypothesisSearch):
        raise ConfigurationError(
            "optimizer", optimizer, "'hypothesis' for a space given as a Hypothesis strategy"
        )
    adapter = adapter_for(optimizer, dims, space if strategy_space else None)
    name = name_of(optimizer)
    started = time.perf_counter()
    with ProgressBar(wanted(progress), budget, f"falsify [{name}]") as bar:
        search = Search(
            run,
            req,
            lv,
            budget=budget,
            seed=seed,
            fidelity_dim=fidelity_dim,
            trace_dir=Path(trace_dir) if trace_dir is not None else None,
            bar=bar,
        )
        adapter.run(search)
    return FalsificationResult(
        requirement=req.formula,
        optimizer=name,
        levels=tuple(search.names),
        budget=budget,
        seed=seed,
        simulations=search.simulations,
        first_violation=search.first,
        first_confirmed=search.confirmed_at,
        lowest=search.lowest,
        counterexample=search.counterexample,
        trials=tuple(search.trials),
        stats=search.stats(),
        wall_time=time.perf_counter() - started,
    )
