"""Multi-fidelity falsification: search cheaply, confirm at higher fidelity (the paper's idea).

::

    from multicosim.falsify import falsify

    def run(mission, fidelity):                      # one simulation -> its trajectory
        with FreshSimulations(fidelity=fidelity)(rover.Rover) as sim:
            return sim.controller.send(mission)

    result = falsify(run, "always (z >= 0)", mst.rover_missions(), levels=("low", "medium"))
    result.counterexample.failing_levels  # ("low", "medium"): confirmed at medium fidelity
    print(result.summary())

The search runs at ``levels[0]`` with Hypothesis: each example is one simulation, its
robustness is the target (``hypothesis.target(-robustness)``) unless ``guided=False``, and
the first violating example is shrunk to a minimal one. That counterexample is then re-run
at every other level, which reports where it still fails. In a pytest test, assert on the
result (``result.assert_holds()`` fails with the summary); with ``trace_dir`` every
confirmation run leaves an MCAP trace and plot there.
"""

from __future__ import annotations

import contextlib
import dataclasses
import random
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Generic, TypeVar

from ._deps import require
from ._errors import ConfigurationError
from .requirements import Evaluation, Requirement
from .strategies import FIDELITY_LEVELS, target_robustness

require("hypothesis", "hypothesis")

import hypothesis  # noqa: E402 - after the dependency check, which names the extra
from hypothesis import strategies as st  # noqa: E402
from hypothesis.errors import NoSuchExample, Unsatisfiable  # noqa: E402

__all__ = [
    "Counterexample",
    "FalsificationResult",
    "LevelResult",
    "examples_to_first_violation",
    "falsify",
]

ExampleT = TypeVar("ExampleT")
Run = Callable[[ExampleT, str], object]


@dataclasses.dataclass(frozen=True)
class LevelResult:
    """One run of a counterexample at a fidelity level."""

    fidelity: str
    evaluation: Evaluation
    wall_time: float
    traces: tuple[Path, ...] = ()

    @property
    def falsified(self) -> bool:
        """Whether the requirement is violated at this level."""
        return not self.evaluation.satisfied


@dataclasses.dataclass(frozen=True)
class Counterexample(Generic[ExampleT]):
    """A violating input and how it fares at each level (search level first)."""

    example: ExampleT
    results: Mapping[str, LevelResult]

    @property
    def failing_levels(self) -> tuple[str, ...]:
        """The levels at which the requirement is still violated, in level order."""
        return tuple(level for level, r in self.results.items() if r.falsified)

    @property
    def highest_failing(self) -> str | None:
        """The most detailed level that still falsifies (None if none does)."""
        failing = self.failing_levels
        return failing[-1] if failing else None


@dataclasses.dataclass(frozen=True)
class FalsificationResult(Generic[ExampleT]):
    """What a falsification found.

    ``examples`` simulations ran during the search (shrinking included);
    ``first_violation`` is the 1-based index of the first violating one (None: none within
    the budget); ``lowest`` is the lowest robustness seen and its example.
    """

    requirement: str
    levels: tuple[str, ...]
    guided: bool
    budget: int
    seed: int
    examples: int
    first_violation: int | None
    lowest: tuple[float, ExampleT] | None
    counterexample: Counterexample[ExampleT] | None
    wall_time: float

    @property
    def falsified(self) -> bool:
        """Whether a violating input was found at the search level."""
        return self.counterexample is not None

    def summary(self) -> str:
        """A human-readable account of the search and the confirmations."""
        mode = "guided" if self.guided else "unguided"
        head = (
            f"falsifying {self.requirement!r} at {self.levels[0]} fidelity ({mode}, seed "
            f"{self.seed}, budget {self.budget}): {self.examples} simulations in "
            f"{self.wall_time:.2f} s"
        )
        if self.counterexample is None:
            best = f"; lowest robustness {self.lowest[0]:.6g}" if self.lowest else ""
            return f"{head}; no violation found{best}"
        lines = [head, f"first violation at example {self.first_violation}"]
        lines.append(f"minimal counterexample: {self.counterexample.example!r}")
        for level, r in self.counterexample.results.items():
            verdict = "FAILS" if r.falsified else "holds"
            lines.append(f"  {level:>6}: {verdict}  {r.evaluation.explain()}")
            lines.extend(f"          trace: {p}" for p in r.traces)
        return "\n".join(lines)

    def assert_holds(self) -> None:
        """Raise AssertionError with the summary if the requirement was falsified."""
        if self.falsified:
            raise AssertionError(self.summary())


def falsify(
    run: Callable[[ExampleT, str], object],
    requirement: Requirement | str,
    inputs: st.SearchStrategy[ExampleT],
    *,
    levels: Sequence[str] = ("low", "medium"),
    budget: int = 100,
    seed: int = 0,
    guided: bool = True,
    shrink: bool = True,
    trace_dir: str | Path | None = None,
) -> FalsificationResult[ExampleT]:
    """Search ``inputs`` at ``levels[0]`` for a violation of ``requirement``; confirm it above.

    ``run(example, fidelity)`` runs one simulation and returns its trajectory (anything
    ``Requirement.evaluate`` accepts). ``budget`` bounds the examples generated; ``seed``
    makes the search repeatable; ``guided=False`` turns off robustness guidance (for
    comparison); ``shrink=False`` keeps the first violating example as found.
    """
    levels = _check_levels(levels)
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 1:
        raise ConfigurationError("budget", budget, "a positive number of examples")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigurationError("seed", seed, "a non-negative integer")
    if not isinstance(inputs, st.SearchStrategy):
        raise ConfigurationError("inputs", inputs, "a Hypothesis strategy")
    req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)
    search_level = levels[0]

    calls = 0
    first: int | None = None
    lowest: tuple[float, Any] | None = None

    def violated(example: ExampleT) -> bool:
        nonlocal calls, first, lowest
        calls += 1
        robustness = req.robustness(run(example, search_level))
        if lowest is None or robustness < lowest[0]:
            lowest = (robustness, example)
        if guided:
            target_robustness(robustness)
        if robustness < 0 and first is None:
            first = calls
        return robustness < 0

    phases = [hypothesis.Phase.generate]
    if guided:
        phases.append(hypothesis.Phase.target)
    if shrink:
        phases.append(hypothesis.Phase.shrink)
    settings = hypothesis.settings(
        max_examples=budget,
        phases=phases,
        database=None,
        deadline=None,
        suppress_health_check=list(hypothesis.HealthCheck),
        # find() would otherwise keep shrinking for a long time on slow simulations.
        report_multiple_bugs=False,
    )
    started = time.perf_counter()
    example: Any = None
    found = False
    try:
        example = _find(inputs, violated, settings, seed)
        found = True
    except (NoSuchExample, Unsatisfiable):
        pass
    counterexample = None
    if found:
        counterexample = Counterexample(
            example,
            {level: _confirm(run, req, example, level, seed, trace_dir) for level in levels},
        )
    return FalsificationResult(
        requirement=req.formula,
        levels=levels,
        guided=guided,
        budget=budget,
        seed=seed,
        examples=calls,
        first_violation=first,
        lowest=lowest,
        counterexample=counterexample,
        wall_time=time.perf_counter() - started,
    )


def _find(
    inputs: st.SearchStrategy[ExampleT],
    condition: Callable[[ExampleT], bool],
    settings: hypothesis.settings,
    seed: int,
) -> ExampleT:
    # find() draws from the Random it is given: the same seed gives the same search.
    return hypothesis.find(inputs, condition, settings=settings, random=random.Random(seed))


def _confirm(
    run: Callable[[ExampleT, str], object],
    requirement: Requirement,
    example: ExampleT,
    level: str,
    seed: int,
    trace_dir: str | Path | None,
) -> LevelResult:
    """Run ``example`` at ``level``; with ``trace_dir``, record it and save the trace there."""
    from . import trace

    metadata = {
        "fidelity": level,
        "seed": seed,
        "failing_example": repr(example),
        "requirement": requirement.formula,
    }
    session = trace.TestTrace(metadata=metadata)
    started = time.perf_counter()
    recording = trace.activate(session) if trace_dir is not None else contextlib.nullcontext()
    with recording:
        evaluation = requirement.evaluate(run(example, level))
    wall = time.perf_counter() - started
    saved: tuple[Path, ...] = ()
    if trace_dir is not None:
        saved = tuple(session.save(Path(trace_dir) / level))
    return LevelResult(level, evaluation, wall, saved)


def _check_levels(levels: Sequence[str]) -> tuple[str, ...]:
    out = tuple(levels) if not isinstance(levels, str) else (levels,)
    bad = [level for level in out if level not in FIDELITY_LEVELS]
    if not out or bad or len(set(out)) != len(out):
        raise ConfigurationError(
            "levels", levels, f"distinct levels from {FIDELITY_LEVELS}, search level first"
        )
    return out


def examples_to_first_violation(
    results: Sequence[FalsificationResult[Any]],
) -> dict[str, float | int | None]:
    """Statistics over several searches (benchmarks): found rate, median and mean index."""
    found = sorted(r.first_violation for r in results if r.first_violation is not None)
    n = len(results)
    median: float | None = None
    if found:
        mid = len(found) // 2
        median = float(found[mid]) if len(found) % 2 else (found[mid - 1] + found[mid]) / 2
    # Not-found searches count as budget + 1: a lower bound on what they would have needed.
    censored = [r.first_violation or r.budget + 1 for r in results]
    return {
        "searches": n,
        "found": len(found),
        "median_found": median,
        "mean_censored": (sum(censored) / n) if n else None,
        "max_found": found[-1] if found else None,
    }
