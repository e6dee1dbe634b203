"""What a falsification found: every simulation, the counterexample and each level's figures."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..requirements import Evaluation

__all__ = [
    "Counterexample",
    "FalsificationResult",
    "LevelResult",
    "LevelStats",
    "Trial",
    "first_violation_statistics",
]


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

    ``found_at`` is the level the search found it at; ``seed`` the seed every level ran it
    with and ``requirement`` the formula it violates.
    [`replay`][multicosim.search.falsify.results.Counterexample.replay] says how to run it again as
    a test; each level's ``traces`` hold what its run recorded (the trace of a failing test: every
    channel, a plot with the vehicle's path).
    """

    example: Any
    found_at: str
    results: Mapping[str, LevelResult]
    seed: int = 0
    requirement: str = ""

    @property
    def replay(self) -> str:
        """A pytest test that runs the counterexample again, and the command that runs it.

        The sample, the lowest level that falsifies and the seed, with ``simulate`` standing
        for the function the search called there.
        """
        level = self.lowest_failing or self.found_at
        return (
            "# in test_counterexample.py, beside your simulate function; run it with\n"
            "#   python -m pytest test_counterexample.py\n"
            "from multicosim import Requirement\n\n\n"
            "def test_counterexample():\n"
            f"    trajectory = simulate({self.example!r}, {level!r}, {self.seed!r})\n"
            f"    Requirement({self.requirement!r}).check(trajectory)\n"
        )

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

    In a test, [`assert_holds`][multicosim.search.falsify.results.FalsificationResult.assert_holds]
    is the assertion: it fails with
    [`summary`][multicosim.search.falsify.results.FalsificationResult.summary] (the counterexample,
    its verdict at each level, its traces and how to replay it) when the requirement was falsified:

    ```python
    def test_overshoot_holds():
        falsify(simulate, "always (overshoot <= 0.15)", space, budget=50).assert_holds()
    ```
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
        # Confirmations happen only above the search's level: a one-level search has none.
        confirmations = len(self.trials) - self.simulations
        ran = f"{self.simulations} simulations"
        if len(self.levels) > 1:
            ran += f" and {confirmations} confirmations at {', '.join(self.levels[1:])}"
        head = (
            f"falsifying {self.requirement!r} from {self.levels[0]} fidelity ({self.optimizer}, "
            f"seed {self.seed}, budget {self.budget}): {ran}, in {self.wall_time:.2f} s"
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
        lines.append(f"lowest fidelity that falsifies: {cx.lowest_failing} (seed {cx.seed})")
        for level, r in cx.results.items():
            verdict = "FAILS" if r.falsified else "holds"
            lines.append(f"  {level:>6}: {verdict}  {r.evaluation.explain()}")
            lines.extend(f"          trace: {p}" for p in r.traces)
        lines.append("replay it as a test:")
        lines.extend(f"    {line}" for line in cx.replay.splitlines())
        saved = self.wall_time_saved
        if saved is not None:
            lines.append(
                f"wall time {self.wall_time:.2f} s against about {self.wall_time_alone:.2f} s "
                f"searching at {self.levels[-1]} alone"
            )
        return "\n".join(lines)

    def assert_holds(self) -> None:
        """Assert that the search found no confirmed counterexample (the pytest assertion).

        Raises ``AssertionError`` with
        [`summary`][multicosim.search.falsify.results.FalsificationResult.summary] as its message if
        the requirement was falsified (a violation every level confirmed); returns None otherwise. A
        violation a higher level did not confirm does not fail it: ``result.first_violation`` tells.
        """
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
