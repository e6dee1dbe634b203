"""What a campaign gives back: each sample's result, the retries, and the whole campaign's."""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..requirements import Evaluation

__all__ = ["STATUSES", "CampaignResult", "RetryEvent", "SampleResult"]

STATUSES = ("ok", "violated", "error", "timeout", "lost")


@dataclasses.dataclass(frozen=True)
class SampleResult:
    """The outcome of one sample.

    ``status`` is one of [`STATUSES`][multicosim.search.campaign.results.STATUSES]: ``ok``
    (requirement holds), ``violated``, ``error`` (simulate raised; see ``error``), ``timeout`` or
    ``lost`` (its worker died more often than the campaign retries). ``attempts`` counts runs (> 1:
    retried); ``trace`` holds the saved MCAP trace of a sample that did not pass.
    """

    index: int
    seed: int
    sample: Any
    status: str
    robustness: float
    summary: Mapping[str, Any]
    error: str = ""
    attempts: int = 1
    wall_time: float = 0.0
    worker: str = ""
    trace: tuple[Path, ...] = ()
    evaluation: Evaluation | None = dataclasses.field(default=None, repr=False, compare=False)

    @property
    def passed(self) -> bool:
        """Whether the sample ran and satisfied the requirement."""
        return self.status == "ok"


@dataclasses.dataclass(frozen=True)
class RetryEvent:
    """A sample re-run because its worker died: ``attempt`` is the run that was lost."""

    index: int
    attempt: int
    reason: str


@dataclasses.dataclass(frozen=True)
class CampaignResult:
    """Every sample's result in index order, the retries, and where the results went."""

    results: tuple[SampleResult, ...]
    retries: tuple[RetryEvent, ...]
    executor: str
    wall_time: float
    csv: Path | None = None
    parquet: Path | None = None

    @property
    def violations(self) -> tuple[SampleResult, ...]:
        """The samples that violate the requirement."""
        return tuple(r for r in self.results if r.status == "violated")

    @property
    def failures(self) -> tuple[SampleResult, ...]:
        """The samples without a robustness: errors, timeouts, lost."""
        return tuple(r for r in self.results if r.status in ("error", "timeout", "lost"))

    @property
    def falsified(self) -> bool:
        """Whether some sample violates the requirement."""
        return bool(self.violations)

    @property
    def lowest(self) -> SampleResult | None:
        """The sample of lowest robustness (None if none has one)."""
        scored = [r for r in self.results if not math.isnan(r.robustness)]
        return min(scored, key=lambda r: r.robustness) if scored else None

    @property
    def rate_per_minute(self) -> float:
        """Samples finished per wall-clock minute."""
        return 60.0 * len(self.results) / self.wall_time if self.wall_time > 0 else 0.0

    def summary(self) -> str:
        """One line: counts by status, retries, throughput."""
        counts = collections.Counter(r.status for r in self.results)
        parts = ", ".join(f"{counts[s]} {s}" for s in STATUSES if counts[s])
        return (
            f"campaign on {self.executor}: {len(self.results)} samples ({parts}), "
            f"{len(self.retries)} retries, {self.wall_time:.2f} s "
            f"({self.rate_per_minute:.0f} simulations/min)"
        )
