"""Falsification: search a space of inputs for a violation, cheaply, and confirm it higher up.

::

    from multicosim.search.falsify import Choice, Integer, falsify

    def simulate(sample, fidelity, seed):            # one simulation -> its trajectory
        world = WorldConfig(timestep=sample["timestep"], iterations=sample["iterations"])
        with rover.Rover(fidelity=fidelity, seed=seed, world=world).start() as simulation:
            return simulation.controller.send(rover.Mission(speed=sample["speed"]))

    space = {
        "speed": (1.0, 10.0),                        # a real interval
        "iterations": Integer(10, 200),              # whole numbers, both ends included
        "timestep": Choice(0.001, 0.002, 0.005),     # one of these values
    }
    result = falsify(simulate, "always (roll <= 0.3)", space, levels=("low", "medium"))
    result.first_violation               # simulations until the first violation
    result.counterexample.failing_levels # ("low", "medium"): confirmed at medium fidelity
    print(result.summary())

**Search.** Every sample is one simulation at the search level (``levels[0]``), scored by
the requirement's robustness, which the optimizer minimizes. ``optimizer`` is a name
(:data:`OPTIMIZERS`: optuna's samplers ``"random"``, ``"tpe"``, ``"cmaes"``, ``"gp"``,
a Latin hypercube ``"lhs"``, ``"hypothesis"`` and psy-taliro's ``"taliro-random"`` and
``"taliro-annealing"``), an optuna sampler, a psy-taliro optimizer, or any object with
``ask()`` (a sample: a mapping, or values in the space's order) and
``tell(sample, robustness)``; by default (None) ``"gp"``, the one that needed the fewest
simulations on the shipped benchmark, where torch is installed (``pip install
'multicosim[gp]'``), else ``"tpe"``. ``space`` may also be a Hypothesis strategy, searched by
``"hypothesis"``. ``budget`` bounds the search-level simulations; ``seed`` fixes the
optimizer and is every simulation's seed, so a seed repeats a search exactly.

**Multi-fidelity.** A sample that violates the requirement is re-run at each further level
in turn (``levels`` are fidelity names, or :class:`Level` objects that bring their own
simulate function: real firmware, say). It is the counterexample once every level confirms
it; where one does not, the search goes on and the optimizer is told that level's
robustness for the sample instead, so it learns where the cheap model is wrong. The result
tells per level how often a violation transferred, and the wall time saved against
searching at the confirming level alone.

**Configuration as search variables.** The space may hold the simulator's configuration
(timestep, solver iterations, noise levels, attack parameters) like any input, and the
fidelity itself: a ``"fidelity"`` dimension (``Choice("low", "medium")``) runs each sample at
the level drawn. The counterexample is then re-run at the levels below the one it was found
at, and :attr:`Counterexample.lowest_failing` names the lowest fidelity that still falsifies.

One callback shape throughout multicosim: ``simulate(sample, fidelity, seed)``, as for
campaigns (:mod:`multicosim.search.campaign`) and psy-taliro (:mod:`multicosim.search.taliro`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import random
import time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from ..core.errors import ConfigurationError
from ..core.fidelity import FIDELITIES
from .campaign import Simulate, check_simulate
from .progress import ProgressBar, wanted
from .requirements import Evaluation, Requirement

__all__ = [
    "DEFAULT_OPTIMIZER",
    "FALLBACK_OPTIMIZER",
    "FIDELITY",
    "OPTIMIZERS",
    "AskTell",
    "Choice",
    "Counterexample",
    "FalsificationResult",
    "HypothesisSearch",
    "Integer",
    "Level",
    "LevelResult",
    "LevelStats",
    "Real",
    "Simulate",
    "Trial",
    "falsify",
    "first_violation_statistics",
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


def default_optimizer() -> str:
    """``DEFAULT_OPTIMIZER`` where torch is installed, else ``FALLBACK_OPTIMIZER``."""
    import importlib.util

    return DEFAULT_OPTIMIZER if importlib.util.find_spec("torch") else FALLBACK_OPTIMIZER


# The name of the dimension that makes the fidelity a search variable.
FIDELITY = "fidelity"
# Optimizers get finite costs: an unbounded robustness (a signal that is never sampled, an
# infinite margin) is clipped to this.
_CLIP = 1e9


# -- the space ------------------------------------------------------------------------------


def _number(field: str, value: object, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigurationError(field, value, allowed)
    return float(value)


@dataclasses.dataclass(frozen=True)
class Real:
    """Real values in ``[low, high]`` (``log``: uniform in the logarithm, for scales)."""

    low: float
    high: float
    log: bool = False

    def __post_init__(self) -> None:
        allowed = "finite low < high" + (" with low > 0 (log scale)" if self.log else "")
        lo = _number("low", self.low, allowed)
        hi = _number("high", self.high, allowed)
        if not lo < hi or (self.log and lo <= 0):
            raise ConfigurationError("(low, high)", (self.low, self.high), allowed)


@dataclasses.dataclass(frozen=True)
class Integer:
    """Whole numbers from ``low`` to ``high``, both included."""

    low: int
    high: int
    log: bool = False

    def __post_init__(self) -> None:
        allowed = "integers low <= high" + (" with low >= 1 (log scale)" if self.log else "")
        for value in (self.low, self.high):
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigurationError("(low, high)", (self.low, self.high), allowed)
        if self.low > self.high or (self.log and self.low < 1):
            raise ConfigurationError("(low, high)", (self.low, self.high), allowed)


class Choice:
    """One of ``values`` (any objects: names, configurations, fidelity levels)."""

    def __init__(self, *values: Any) -> None:
        if not values:
            raise ConfigurationError("values", values, "at least one value to choose from")
        self.values: tuple[Any, ...] = values

    def __repr__(self) -> str:
        return f"Choice({', '.join(map(repr, self.values))})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Choice) and self.values == other.values

    def __hash__(self) -> int:
        return hash(self.values)


Dimension = Real | Integer | Choice


def _dimensions(space: Mapping[str, Any]) -> dict[str, Dimension]:
    if not space:
        raise ConfigurationError("space", space, "at least one dimension")
    out: dict[str, Dimension] = {}
    for name, dim in space.items():
        if not isinstance(name, str) or not name:
            raise ConfigurationError("space", name, "dimension names that are non-empty strings")
        if isinstance(dim, Real | Integer | Choice):
            out[name] = dim
        elif isinstance(dim, tuple | list) and len(dim) == 2:
            try:
                out[name] = Real(*dim)
            except ConfigurationError:
                raise ConfigurationError(
                    f"space[{name!r}]", dim, "(low, high) with finite low < high"
                ) from None
        else:
            raise ConfigurationError(
                f"space[{name!r}]", dim, "(low, high), Real(...), Integer(low, high) or Choice(...)"
            )
    return out


def _from_unit(dim: Dimension, u: float) -> Any:
    """The value at ``u`` in [0, 1] along ``dim`` (what a Latin hypercube or psy-taliro draws)."""
    u = min(max(u, 0.0), 1.0)
    if isinstance(dim, Choice):
        return dim.values[min(int(u * len(dim.values)), len(dim.values) - 1)]
    if isinstance(dim, Integer):
        if dim.log:
            lo, hi = math.log(dim.low), math.log(dim.high + 1)
            return min(math.floor(math.exp(lo + u * (hi - lo))), dim.high)
        return min(math.floor(dim.low + u * (dim.high + 1 - dim.low)), dim.high)
    if dim.log:
        return math.exp(math.log(dim.low) + u * (math.log(dim.high) - math.log(dim.low)))
    return dim.low + u * (dim.high - dim.low)


# -- levels ---------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Level:
    """A rung of the fidelity ladder: ``name``, and how to simulate there.

    ``simulate`` (the same shape as falsify's: ``(sample, fidelity, seed)``, called with
    ``fidelity=name``) runs a sample at this level; None uses the function given to
    :func:`falsify`. A level of its own simulate function plugs in what falsify knows nothing
    of (real firmware in the loop, hardware, another simulator).
    """

    name: str
    simulate: Simulate | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigurationError("level name", self.name, "a non-empty string")
        if self.simulate is not None:
            check_simulate(self.simulate, f"levels[{self.name!r}].simulate")


def _levels(levels: Sequence[str | Level | Simulate] | str) -> tuple[Level, ...]:
    given: Sequence[Any] = (levels,) if isinstance(levels, str | Level) else levels
    allowed = (
        f"distinct levels, search level first: names from {FIDELITIES}, Level objects "
        "or simulate functions"
    )
    out: list[Level] = []
    if not isinstance(given, Sequence) or not given:
        raise ConfigurationError("levels", levels, allowed)
    for item in given:
        if isinstance(item, Level):
            out.append(item)
        elif isinstance(item, str):
            if item not in FIDELITIES:
                raise ConfigurationError("levels", levels, allowed)
            out.append(Level(item))
        elif callable(item):
            name = getattr(item, "name", None) or getattr(item, "__name__", None)
            out.append(Level(str(name or repr(item)), item))
        else:
            raise ConfigurationError("levels", levels, allowed)
    names = [level.name for level in out]
    if len(set(names)) != len(names):
        raise ConfigurationError("levels", names, allowed)
    return tuple(out)


# -- results --------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Trial:
    """One simulation: ``sample`` at ``level``, its robustness and wall time.

    ``search`` is the 1-based index of the search sample it belongs to (a confirmation
    shares its sample's index).
    """

    search: int
    sample: Any
    level: str
    robustness: float
    wall_time: float


@dataclasses.dataclass(frozen=True)
class LevelResult:
    """One run of the counterexample at a fidelity level."""

    fidelity: str
    evaluation: Evaluation
    wall_time: float
    traces: tuple[Path, ...] = ()

    @property
    def falsified(self) -> bool:
        """Whether the requirement is violated at this level."""
        return not self.evaluation.satisfied


@dataclasses.dataclass(frozen=True)
class Counterexample:
    """A violating sample and how it fares at each level it ran at (in level order).

    ``found_at`` is the level the search found it at.
    """

    example: Any
    found_at: str
    results: Mapping[str, LevelResult]

    @property
    def failing_levels(self) -> tuple[str, ...]:
        """The levels at which the requirement is violated, in level order."""
        return tuple(level for level, r in self.results.items() if r.falsified)

    @property
    def highest_failing(self) -> str | None:
        """The most detailed level that falsifies (None if none does)."""
        failing = self.failing_levels
        return failing[-1] if failing else None

    @property
    def lowest_failing(self) -> str | None:
        """The lowest fidelity that still falsifies: the cheapest place to study it."""
        failing = self.failing_levels
        return failing[0] if failing else None


@dataclasses.dataclass(frozen=True)
class LevelStats:
    """What one level did in a search.

    ``runs`` simulations took ``wall_time`` s; ``tried`` violations found below were
    re-run here, ``transferred`` of them violated here too.
    """

    level: str
    runs: int
    wall_time: float
    tried: int
    transferred: int

    @property
    def transfer_rate(self) -> float | None:
        """The share of violations found below that hold here (None: none was tried)."""
        return self.transferred / self.tried if self.tried else None

    @property
    def mean_wall_time(self) -> float | None:
        """Mean wall time of one simulation here (None: none ran)."""
        return self.wall_time / self.runs if self.runs else None


@dataclasses.dataclass(frozen=True)
class FalsificationResult:
    """What a falsification found.

    ``simulations`` search samples were simulated (``budget`` bounds them; confirmations
    are not counted); ``first_violation`` is how many it took to the first violation (None:
    none within the budget) and ``first_confirmed`` to the first counterexample every level
    confirms. ``lowest`` is the lowest robustness the optimizer was told and its sample.
    ``trials`` lists every simulation, confirmations included; ``stats`` sums them per level.
    """

    requirement: str
    optimizer: str
    levels: tuple[str, ...]
    budget: int
    seed: int
    simulations: int
    first_violation: int | None
    first_confirmed: int | None
    lowest: tuple[float, Any] | None
    counterexample: Counterexample | None
    trials: tuple[Trial, ...]
    stats: Mapping[str, LevelStats]
    wall_time: float

    @property
    def falsified(self) -> bool:
        """Whether a counterexample that every level confirms was found."""
        return self.counterexample is not None

    @property
    def transfer_rates(self) -> dict[str, float | None]:
        """Per confirming level, the share of violations found below that held there."""
        return {name: s.transfer_rate for name, s in self.stats.items() if name != self.levels[0]}

    @property
    def wall_time_alone(self) -> float | None:
        """An estimate of the wall time of the same search run at the top level alone.

        As many simulations as this search needed, at the top level's mean wall time per
        simulation (None when nothing ran there). ``bench/bench_search.py`` measures it
        instead, by searching at that level.
        """
        top = self.stats[self.levels[-1]].mean_wall_time
        if top is None or len(self.levels) < 2:
            return None
        return (self.first_confirmed or self.simulations) * top

    @property
    def wall_time_saved(self) -> float | None:
        """``wall_time_alone`` less the wall time this search took (None: no estimate)."""
        alone = self.wall_time_alone
        return None if alone is None else alone - self.wall_time

    def summary(self) -> str:
        """A human-readable account of the search and the confirmations."""
        head = (
            f"falsifying {self.requirement!r} from {self.levels[0]} fidelity ({self.optimizer}, "
            f"seed {self.seed}, budget {self.budget}): {self.simulations} simulations, "
            f"{len(self.trials)} with confirmations, in {self.wall_time:.2f} s"
        )
        lines = [head]
        for name in self.levels[1:]:
            s = self.stats[name]
            if s.tried:
                lines.append(
                    f"  {name}: {s.transferred}/{s.tried} violations from below transferred"
                )
        if self.counterexample is None:
            best = f"; lowest robustness {self.lowest[0]:.6g}" if self.lowest else ""
            if self.first_violation is not None:
                lines.append(f"first violation at simulation {self.first_violation}, unconfirmed")
            lines.append(f"no confirmed violation{best}")
            return "\n".join(lines)
        cx = self.counterexample
        lines.append(
            f"first violation at simulation {self.first_violation}; confirmed at "
            f"{self.first_confirmed}"
        )
        lines.append(f"counterexample (found at {cx.found_at}): {cx.example!r}")
        lines.append(f"lowest fidelity that falsifies: {cx.lowest_failing}")
        for level, r in cx.results.items():
            verdict = "FAILS" if r.falsified else "holds"
            lines.append(f"  {level:>6}: {verdict}  {r.evaluation.explain()}")
            lines.extend(f"          trace: {p}" for p in r.traces)
        saved = self.wall_time_saved
        if saved is not None:
            lines.append(
                f"wall time {self.wall_time:.2f} s against about {self.wall_time_alone:.2f} s "
                f"searching at {self.levels[-1]} alone"
            )
        return "\n".join(lines)

    def assert_holds(self) -> None:
        """Raise AssertionError with the summary if the requirement was falsified."""
        if self.falsified:
            raise AssertionError(self.summary())


def first_violation_statistics(results: Sequence[FalsificationResult]) -> dict[str, Any]:
    """Over several searches (benchmarks): success rate and median simulations to the first
    violation (a search that found none counts as ``budget + 1``: a lower bound)."""
    n = len(results)
    found = [r.first_violation for r in results if r.first_violation is not None]
    censored = sorted(
        r.first_violation if r.first_violation is not None else r.budget + 1 for r in results
    )
    median: float | None = None
    if censored:
        mid = n // 2
        median = float(censored[mid]) if n % 2 else (censored[mid - 1] + censored[mid]) / 2
    return {
        "searches": n,
        "found": len(found),
        "success_rate": len(found) / n if n else None,
        "median": median,
        "mean_censored": sum(censored) / n if n else None,
    }


# -- optimizers -----------------------------------------------------------------------------


@runtime_checkable
class AskTell(Protocol):
    """Any optimizer with an ask/tell interface.

    ``ask()`` returns a sample: a mapping of dimension name to value, or the values in the
    space's order. ``tell(asked, robustness)`` gets back what ``ask`` returned, scored (the
    optimizer should minimize it).
    """

    def ask(self) -> Any: ...
    def tell(self, asked: Any, robustness: float) -> Any: ...


@dataclasses.dataclass(frozen=True)
class HypothesisSearch:
    """Hypothesis as the optimizer: ``guided`` targets the robustness, ``shrink`` shrinks the
    counterexample to a minimal one (each shrinking step is a simulation, and a confirmation
    at the higher levels when it violates; shrinking is not bounded by the budget)."""

    guided: bool = True
    shrink: bool = True


class _Done(Exception):
    """The search is over: a confirmed counterexample, or the budget spent."""


class _Search:
    """The objective every optimizer minimizes, and everything the search has seen."""

    def __init__(
        self,
        run: Simulate,
        requirement: Requirement,
        levels: tuple[Level, ...],
        *,
        budget: int,
        seed: int,
        fidelity_dim: bool,
        trace_dir: Path | None,
        bar: ProgressBar,
    ) -> None:
        self.run = run
        self.requirement = requirement
        self.levels = levels
        self.names = [level.name for level in levels]
        self.budget = budget
        self.seed = seed
        self.fidelity_dim = fidelity_dim
        self.trace_dir = trace_dir
        self.bar = bar
        self.simulations = 0
        self.first: int | None = None
        self.confirmed_at: int | None = None
        self.lowest: tuple[float, Any] | None = None
        self.counterexample: Counterexample | None = None
        self.trials: list[Trial] = []
        self.tried = dict.fromkeys(self.names, 0)
        self.transferred = dict.fromkeys(self.names, 0)
        # Hypothesis asks again for samples it has seen (shrinking) and wants their verdict;
        # other optimizers pay a simulation for a repeated sample, so that each ask counts.
        self.reuse = False
        self.verdicts: dict[str, tuple[float, Counterexample | None]] = {}

    @property
    def done(self) -> bool:
        return self.counterexample is not None or self.simulations >= self.budget

    def objective(self, sample: Any) -> float:
        """Simulate ``sample`` (and confirm a violation); the robustness to tell the optimizer.

        Raises _Done once the search is over (before simulating anything more).
        """
        if self.done:
            raise _Done
        value, _ = self.evaluate(sample)
        if self.counterexample is not None:
            raise _Done
        return value

    def evaluate(self, sample: Any) -> tuple[float, Counterexample | None]:
        """Simulate and confirm ``sample``: (robustness to tell, counterexample or None)."""
        key = repr(sample)
        if self.reuse and key in self.verdicts:
            return self.verdicts[key]
        self.simulations += 1
        index = self.simulations
        level = self.names[0]
        if self.fidelity_dim:
            sample = dict(sample)
            level = sample.pop(FIDELITY)
        results: dict[str, LevelResult] = {}
        results[level] = self._simulate(index, sample, level)
        value = results[level].evaluation.robustness
        found: Counterexample | None = None
        if value < 0:
            if self.first is None:
                self.first = index
            value, found = self._confirm(index, sample, level, results)
        told = max(-_CLIP, min(_CLIP, value))
        if self.lowest is None or told < self.lowest[0]:
            self.lowest = (told, sample)
        if found is not None and self.counterexample is None:
            self.counterexample = found
            self.confirmed_at = index
        self.verdicts[key] = (told, found)
        best = f"best robustness {self.lowest[0]:.4g}" if self.lowest else ""
        self.bar.advance(best)
        return told, found

    def _confirm(
        self, index: int, sample: Any, level: str, results: dict[str, LevelResult]
    ) -> tuple[float, Counterexample | None]:
        """Re-run a violation above ``level``; below too once every level above agrees."""
        at = self.names.index(level)
        for name in self.names[at + 1 :]:
            self.tried[name] += 1
            result = results[name] = self._simulate(index, sample, name)
            if not result.falsified:
                # What the higher level said replaces what the cheaper one did.
                return result.evaluation.robustness, None
            self.transferred[name] += 1
        for name in self.names[:at]:
            results[name] = self._simulate(index, sample, name)
        ordered = {name: results[name] for name in self.names if name in results}
        worst = max(r.evaluation.robustness for r in ordered.values() if r.falsified)
        return worst, Counterexample(sample, level, ordered)

    def _simulate(self, index: int, sample: Any, level: str) -> LevelResult:
        from .. import trace

        spec = self.levels[self.names.index(level)]
        run = spec.simulate or self.run
        session = None
        recording: contextlib.AbstractContextManager[Any] = contextlib.nullcontext()
        if self.trace_dir is not None:
            session = trace.TestTrace(
                metadata={
                    "fidelity": level,
                    "seed": self.seed,
                    "failing_example": repr(sample),
                    "requirement": self.requirement.formula,
                }
            )
            recording = trace.activate(session)
        started = time.perf_counter()
        with recording:
            evaluation = self.requirement.evaluate(run(sample, level, self.seed))
        wall = time.perf_counter() - started
        self.trials.append(Trial(index, sample, level, evaluation.robustness, wall))
        saved: tuple[Path, ...] = ()
        if session is not None and self.trace_dir is not None and not evaluation.satisfied:
            directory = self.trace_dir / f"sample-{index:05d}" / level
            saved = tuple(session.save(directory))
        return LevelResult(level, evaluation, wall, saved)

    def stats(self) -> dict[str, LevelStats]:
        out = {}
        for name in self.names:
            trials = [t for t in self.trials if t.level == name]
            out[name] = LevelStats(
                name,
                len(trials),
                sum(t.wall_time for t in trials),
                self.tried[name],
                self.transferred[name],
            )
        return out


@contextlib.contextmanager
def _quiet_optuna() -> Iterator[Any]:
    from ..core.deps import require

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
    from ..core.deps import require

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


def _run_optuna(search: _Search, dims: Mapping[str, Dimension], sampler: Any) -> None:
    with _quiet_optuna() as optuna:
        study = sampler if isinstance(sampler, optuna.Study) else None
        if study is None:
            study = optuna.create_study(sampler=sampler, direction="minimize")
        distributions = _distributions(optuna, dims)
        while not search.done:
            trial = study.ask(distributions)
            try:
                value = search.objective(_decode(dims, trial.params))
            except _Done:
                if search.counterexample is not None and search.lowest is not None:
                    study.tell(trial, search.lowest[0])
                else:
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                break
            study.tell(trial, value)


def _run_lhs(search: _Search, dims: Mapping[str, Dimension], seed: int) -> None:
    from ..core.deps import require

    qmc = require("scipy.stats.qmc", "search")
    design = qmc.LatinHypercube(d=len(dims), rng=seed).random(search.budget)
    names = list(dims)
    for row in design:
        sample = {
            name: _from_unit(dims[name], float(u)) for name, u in zip(names, row, strict=True)
        }
        try:
            search.objective(sample)
        except _Done:
            return


def _run_ask_tell(search: _Search, dims: Mapping[str, Dimension], optimizer: Any) -> None:
    names = list(dims)
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
        except _Done:
            if search.counterexample is not None and search.lowest is not None:
                optimizer.tell(asked, search.lowest[0])
            return
        optimizer.tell(asked, value)


def _run_taliro(search: _Search, dims: Mapping[str, Dimension], optimizer: Any) -> None:
    from staliro.signals import Interval

    names = list(dims)

    class Objective:
        def eval_sample(self, sample: Any) -> float:
            u = [float(v) for v in sample.values]
            return search.objective(
                {n: _from_unit(dims[n], x) for n, x in zip(names, u, strict=True)}
            )

        def eval_samples(self, samples: Any) -> list[float]:
            return [self.eval_sample(s) for s in samples]

    # Every dimension as [0, 1]: integers and choices map onto it as in a Latin hypercube.
    from .taliro import staliro_optimizers

    params = staliro_optimizers.Optimizer.Params(
        seed=search.seed + 1,  # psy-taliro wants seeds > 0
        budget=search.budget,
        input_bounds=[Interval(0.0, 1.0) for _ in names],
    )
    with contextlib.suppress(_Done):
        optimizer.optimize(Objective(), params)


def _run_hypothesis(search: _Search, strategy: Any, options: HypothesisSearch) -> None:
    from ..core.deps import require

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


def _optimizer_name(optimizer: Any) -> str:
    if isinstance(optimizer, str):
        return optimizer
    if isinstance(optimizer, HypothesisSearch):
        return "hypothesis" + ("" if optimizer.guided else " (unguided)")
    return type(optimizer).__name__


def _is_strategy(space: object) -> bool:
    try:
        from hypothesis.strategies import SearchStrategy
    except ImportError:
        return False
    return isinstance(space, SearchStrategy)


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
    ``Requirement.evaluate`` accepts). See the module docstring for ``space``, ``optimizer``
    and ``levels``. With ``trace_dir``, every violating simulation leaves its MCAP trace and
    plot under ``trace_dir/sample-NNNNN/LEVEL``. ``progress`` shows a bar on stderr (None:
    when stderr is a terminal).
    """
    run = check_simulate(run, "run")
    if optimizer is None:
        optimizer = default_optimizer()
    lv = _levels(levels)
    budget = _check_int("budget", budget, 1, "a positive number of simulations")
    seed = _check_int("seed", seed, 0, "a non-negative integer")
    req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)
    strategy_space = _is_strategy(space)
    if not strategy_space and not isinstance(space, Mapping):
        raise ConfigurationError(
            "space", space, "a mapping of name to (low, high), Integer or Choice, or a strategy"
        )
    dims = {} if strategy_space else _dimensions(space)
    fidelity_dim = FIDELITY in dims
    if fidelity_dim:
        dim = dims[FIDELITY]
        names = [level.name for level in lv]
        if not isinstance(dim, Choice) or any(v not in names for v in dim.values):
            raise ConfigurationError(
                f"space[{FIDELITY!r}]", dim, f"Choice(...) of level names from {names}"
            )
    if isinstance(optimizer, str) and optimizer not in OPTIMIZERS:
        raise ConfigurationError(
            "optimizer",
            optimizer,
            f"one of {OPTIMIZERS}, an optuna sampler, a psy-taliro optimizer or an ask/tell object",
        )
    if optimizer == "hypothesis":
        optimizer = HypothesisSearch()
    if strategy_space and not isinstance(optimizer, HypothesisSearch):
        raise ConfigurationError(
            "optimizer", optimizer, "'hypothesis' for a space given as a Hypothesis strategy"
        )
    kind = _kind(optimizer)
    name = _optimizer_name(optimizer)
    started = time.perf_counter()
    with ProgressBar(wanted(progress), budget, f"falsify [{name}]") as bar:
        search = _Search(
            run,
            req,
            lv,
            budget=budget,
            seed=seed,
            fidelity_dim=fidelity_dim,
            trace_dir=Path(trace_dir) if trace_dir is not None else None,
            bar=bar,
        )
        if isinstance(optimizer, HypothesisSearch):
            _run_hypothesis(search, space if strategy_space else _strategy_of(dims), optimizer)
        elif kind == "optuna-name":
            with _quiet_optuna():
                sampler = _sampler(optimizer, seed)
            _run_optuna(search, dims, sampler)
        elif kind == "optuna":
            _run_optuna(search, dims, optimizer)
        elif optimizer == "lhs":
            _run_lhs(search, dims, seed)
        elif kind == "taliro":
            _run_taliro(search, dims, _taliro_optimizer(optimizer))
        else:
            _run_ask_tell(search, dims, optimizer)
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


def _kind(optimizer: Any) -> str:
    """Which driver runs ``optimizer``; ConfigurationError for what none can."""
    if isinstance(optimizer, HypothesisSearch):
        return "hypothesis"
    if isinstance(optimizer, str):
        if optimizer in ("random", "tpe", "cmaes", "gp"):
            return "optuna-name"
        return "taliro" if optimizer.startswith("taliro-") else optimizer
    module = type(optimizer).__module__
    if module.startswith("optuna"):
        return "optuna"
    if module.startswith("staliro"):
        return "taliro"
    if isinstance(optimizer, AskTell):
        return "ask-tell"
    raise ConfigurationError(
        "optimizer",
        optimizer,
        f"one of {OPTIMIZERS}, an optuna sampler, a psy-taliro optimizer or an ask/tell object",
    )


def _taliro_optimizer(optimizer: Any) -> Any:
    from .taliro import staliro_optimizers

    if optimizer == "taliro-random":
        return staliro_optimizers.UniformRandom()
    if optimizer == "taliro-annealing":
        return staliro_optimizers.DualAnnealing()
    return optimizer
