"""The objective every optimizer minimizes, and the bookkeeping of the search behind it.

``Search`` simulates a sample at the search level, confirms a violation at the other
levels, and tells the optimizer the robustness to minimize; it raises ``Done`` once a
counterexample is confirmed or the budget is spent.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Any

from ..campaign.simulate import Simulate
from ..progress import ProgressBar
from ..requirements import Requirement
from .levels import Level
from .results import Counterexample, LevelResult, LevelStats, Trial
from .space import FIDELITY

__all__ = ["Done", "Search"]

# Optimizers get finite costs: an unbounded robustness (a signal that is never sampled, an
# infinite margin) is clipped to this.
_CLIP = 1e9


class Done(Exception):
    """The search is over: a confirmed counterexample, or the budget spent."""


class Search:
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
        from ... import trace

        # Inside a test (pytest's trace is active), the test's trace gets the last violating
        # run's recording: a failing falsification test leaves the trace a failing test does.
        self.test_trace = trace.active()
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
        """Whether the search is over: a confirmed counterexample, or the budget spent."""
        return self.counterexample is not None or self.simulations >= self.budget

    def objective(self, sample: Any) -> float:
        """Simulate ``sample`` (and confirm a violation); the robustness to tell the optimizer.

        Raises Done once the search is over (before simulating anything more).
        """
        if self.done:
            raise Done
        value, _ = self.evaluate(sample)
        if self.counterexample is not None:
            raise Done
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
        return worst, Counterexample(
            sample, level, ordered, seed=self.seed, requirement=self.requirement.formula
        )

    def _simulate(self, index: int, sample: Any, level: str) -> LevelResult:
        from ... import trace

        spec = self.levels[self.names.index(level)]
        run = spec.simulate or self.run
        session = None
        recording: contextlib.AbstractContextManager[Any] = contextlib.nullcontext()
        if self.trace_dir is not None or self.test_trace is not None:
            session = trace.TestTrace(
                metadata={
                    "fidelity": level,
                    "seed": self.seed,
                    "failing_example": repr(sample),
                    "requirement": self.requirement.formula,
                },
                record_started=True,
            )
            recording = trace.activate(session)
        started = time.perf_counter()
        with recording:
            evaluation = self.requirement.evaluate(run(sample, level, self.seed))
        wall = time.perf_counter() - started
        self.trials.append(Trial(index, sample, level, evaluation.robustness, wall))
        saved: tuple[Path, ...] = ()
        if session is not None and self.test_trace is not None and not session.deterministic:
            # What real firmware did here decides which run the search hands over.
            self.test_trace.depends_on_firmware = True
        if session is not None and not evaluation.satisfied:
            if self.test_trace is not None:
                self.test_trace.take(session)
            if self.trace_dir is not None:
                directory = self.trace_dir / f"sample-{index:05d}" / level
                saved = tuple(session.save(directory))
        return LevelResult(level, evaluation, wall, saved)

    def stats(self) -> dict[str, LevelStats]:
        """What each level did so far."""
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
