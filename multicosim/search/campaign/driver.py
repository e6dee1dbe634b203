"""The driver's side of a campaign: samples handed to an executor, results gathered.

[`Campaign`][multicosim.search.campaign.driver.Campaign] keeps an executor's workers open across
batches, gives each sample its seed
([`simulate.sample_seed`][multicosim.search.campaign.simulate.sample_seed]), retries a sample whose
worker died, cancels one past its timeout, and writes the results under ``output``;
[`run_campaign`][multicosim.search.campaign.driver.run_campaign] is one batch of it.
"""

from __future__ import annotations

import collections
import dataclasses
import logging
import math
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from ...core.errors import ConfigurationError, MulticosimError
from ...core.fidelity import check_fidelity
from ..progress import ProgressBar, wanted
from ..requirements import Requirement
from .executors import (
    Backend,
    ExecutorSpec,
    ProcessExecutor,
    RayExecutor,
    TaskFailed,
    WorkerLost,
    executor_of,
)
from .output import save_traces, write_results
from .results import CampaignResult, RetryEvent, SampleResult
from .simulate import Simulate, check_seed, check_simulate, sample_seed
from .worker import RequirementSpec, Task

__all__ = ["Campaign", "CampaignInterrupted", "run_campaign"]

log = logging.getLogger(__name__)

# How long past its timeout a sample may run before the driver kills its worker: the
# worker's own alarm normally ends it at the timeout; this catches code that never returns
# to the interpreter (a C call that blocks).
_GRACE = 5.0
_POLL = 0.2


class CampaignInterrupted(MulticosimError, KeyboardInterrupt):
    """Ctrl-C stopped the campaign; ``result`` holds the samples that had finished.

    A ``KeyboardInterrupt`` too, so that an uncaught one still ends the program (and pytest's
    session) as Ctrl-C does.
    """

    def __init__(self, result: CampaignResult) -> None:
        self.result = result
        super().__init__(f"campaign interrupted after {len(result.results)} samples")


# Shown as ``multicosim.CampaignInterrupted``, as every error is (see multicosim.core.errors).
CampaignInterrupted.__module__ = "multicosim"


def _status(results: Sequence[SampleResult], retries: int) -> str:
    counts = collections.Counter(r.status for r in results)
    bad = counts["error"] + counts["timeout"] + counts["lost"]
    scored = [r.robustness for r in results if not math.isnan(r.robustness)]
    best = f"best robustness {min(scored):.4g}, " if scored else ""
    return f"{best}{counts['violated']} violated, {bad} failed, {retries} retried"


@dataclasses.dataclass
class _Flight:
    index: int
    sample: Any
    attempt: int
    submitted: float


class Campaign:
    """A campaign kept open across batches (an optimizer's ask/tell loop):

    ```python
    with Campaign(simulate, requirement, executor="ray") as campaign:
        for batch in optimizer:                   # any number of batches
            results = campaign.evaluate(batch)    # in the batch's order
    campaign.result()
    ```

    Sample indices, hence seeds, continue from one batch to the next. Arguments are those of
    [`run_campaign`][multicosim.search.campaign.driver.run_campaign].
    """

    def __init__(
        self,
        simulate: Simulate,
        requirement: Requirement | str,
        *,
        fidelity: str = "low",
        seed: int = 0,
        executor: ExecutorSpec = None,
        ray_address: str | None = None,
        timeout: float = 300.0,
        max_retries: int = 2,
        output: str | Path | None = None,
        progress: bool | None = None,
        on_result: Callable[[SampleResult], None] | None = None,
    ) -> None:
        check_simulate(simulate)
        check_fidelity(fidelity)
        self.seed = check_seed(seed)
        if (
            isinstance(timeout, bool)
            or not isinstance(timeout, int | float)
            or not math.isfinite(timeout)
            or timeout <= 0
        ):
            raise ConfigurationError("timeout", timeout, "a positive number of seconds")
        if isinstance(max_retries, bool) or not isinstance(max_retries, int) or max_retries < 0:
            raise ConfigurationError("max_retries", max_retries, "a non-negative integer")
        self._executor = executor_of(executor, ray_address)
        # The caller's executor object is theirs to shut down; one we made is ours.
        self._own_executor = not isinstance(executor, ProcessExecutor | RayExecutor)
        req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)
        self.requirement = req
        self._spec = RequirementSpec.of(req)
        self.simulate = simulate
        self.fidelity = fidelity
        self.timeout = float(timeout)
        self.max_retries = max_retries
        self.output = Path(output) if output is not None else None
        self.on_result = on_result
        self._progress = ProgressBar(wanted(progress), 0, f"campaign [{self._executor.name}]")
        self._backend: Backend | None = None
        self._results: dict[int, SampleResult] = {}
        self._retries: list[RetryEvent] = []
        self._next = 0
        self._started = time.perf_counter()
        self._written: tuple[Path | None, Path | None] = (None, None)

    def __enter__(self) -> Campaign:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Stop the workers (and a Ray connection this campaign made)."""
        backend, self._backend = self._backend, None
        self._progress.close()
        try:
            if backend is not None:
                backend.close()
        finally:
            if self._own_executor and isinstance(self._executor, RayExecutor):
                self._executor.shutdown()

    def evaluate(self, samples: Iterable[Any]) -> list[SampleResult]:
        """Run ``samples``; return their results in the order given (streamed as they finish)."""
        batch = list(samples)
        if not batch:
            raise ConfigurationError("samples", batch, "at least one sample")
        first = self._next
        self._next += len(batch)
        self._progress.grow(len(batch))
        queue = collections.deque(
            _Flight(first + i, sample, 1, 0.0) for i, sample in enumerate(batch)
        )
        if self._backend is None:
            self._backend = self._executor.open()
        backend = self._backend
        flying: dict[Any, _Flight] = {}
        try:
            while queue or flying:
                while queue and len(flying) < backend.capacity:
                    flight = queue.popleft()
                    flight.submitted = time.monotonic()
                    flying[backend.submit(self._task(flight))] = flight
                for handle in backend.wait(list(flying), _POLL):
                    self._settle(backend, handle, flying.pop(handle), queue)
                self._cancel_overdue(backend, flying)
        except KeyboardInterrupt:
            backend.kill(list(flying))
            self.close()
            raise CampaignInterrupted(self.result()) from None
        self._write()
        return [self._results[first + i] for i in range(len(batch))]

    def _task(self, flight: _Flight) -> Task:
        return Task(
            index=flight.index,
            seed=sample_seed(self.seed, flight.index),
            sample=flight.sample,
            fidelity=self.fidelity,
            simulate=self.simulate,
            requirement=self._spec,
            timeout=self.timeout,
            record=self.output is not None,
        )

    def _settle(
        self, backend: Backend, handle: Any, flight: _Flight, queue: collections.deque[_Flight]
    ) -> None:
        try:
            outcome = backend.outcome(handle)
        except WorkerLost as exc:
            self._retries.append(RetryEvent(flight.index, flight.attempt, str(exc)))
            if flight.attempt <= self.max_retries:
                log.warning("campaign sample %d lost its worker (%s): retrying", flight.index, exc)
                # To the front: a retried sample should not wait behind the whole campaign.
                queue.appendleft(_Flight(flight.index, flight.sample, flight.attempt + 1, 0.0))
                return
            self._finish(flight, "lost", f"its worker died {flight.attempt} times: {exc}")
            return
        except TaskFailed as exc:
            self._finish(flight, "error", str(exc))
            return
        traces: tuple[Path, ...] = ()
        if self.output is not None:
            traces = save_traces(self.output, outcome.index, outcome.traces)
        self._add(
            SampleResult(
                index=flight.index,
                seed=sample_seed(self.seed, flight.index),
                sample=flight.sample,
                status=outcome.status,
                robustness=outcome.robustness,
                summary=outcome.summary,
                error=outcome.error,
                attempts=flight.attempt,
                wall_time=outcome.wall_time,
                worker=outcome.worker,
                trace=traces,
                evaluation=outcome.evaluation,
            )
        )

    def _finish(self, flight: _Flight, status: str, error: str) -> None:
        self._add(
            SampleResult(
                index=flight.index,
                seed=sample_seed(self.seed, flight.index),
                sample=flight.sample,
                status=status,
                robustness=math.nan,
                summary={},
                error=error,
                attempts=flight.attempt,
            )
        )

    def _cancel_overdue(self, backend: Backend, flying: dict[Any, _Flight]) -> None:
        now = time.monotonic()
        overdue = [h for h, f in flying.items() if now - f.submitted > self.timeout + _GRACE]
        if not overdue:
            return
        backend.kill(overdue)
        for handle in overdue:
            flight = flying.pop(handle)
            self._finish(flight, "timeout", f"killed {_GRACE:g} s after its timeout")

    def _add(self, result: SampleResult) -> None:
        self._results[result.index] = result
        if self.on_result is not None:
            self.on_result(result)
        self._progress.advance(_status(list(self._results.values()), len(self._retries)))

    def result(self) -> CampaignResult:
        """Every result so far, in index order (also written under ``output``)."""
        csv_path, parquet_path = self._write()
        return CampaignResult(
            results=tuple(self._results[i] for i in sorted(self._results)),
            retries=tuple(self._retries),
            executor=self._executor.name,
            wall_time=time.perf_counter() - self._started,
            csv=csv_path,
            parquet=parquet_path,
        )

    def _write(self) -> tuple[Path | None, Path | None]:
        if self.output is None or not self._results:
            return self._written
        results = [self._results[i] for i in sorted(self._results)]
        self._written = write_results(self.output, results)
        return self._written


def run_campaign(
    simulate: Simulate,
    requirement: Requirement | str,
    samples: Iterable[Any],
    *,
    fidelity: str = "low",
    seed: int = 0,
    executor: ExecutorSpec = None,
    ray_address: str | None = None,
    timeout: float = 300.0,
    max_retries: int = 2,
    output: str | Path | None = None,
    progress: bool | None = None,
    on_result: Callable[[SampleResult], None] | None = None,
) -> CampaignResult:
    """Evaluate every sample as one simulation; return the results in sample order.

    ``simulate(sample, fidelity, seed)`` returns a trajectory; ``requirement`` gives each
    its robustness. ``executor`` is ``"process"`` (default), ``"ray"``, a
    [`ProcessExecutor`][multicosim.search.campaign.ProcessExecutor] or a
    [`RayExecutor`][multicosim.search.campaign.RayExecutor] (``ray_address`` implies Ray).
    ``timeout`` (s) cancels a sample that runs longer; a sample whose worker dies is re-run up to
    ``max_retries`` times. With ``output``, results go to ``output/results.csv`` and the traces of
    samples that did not pass to ``output/traces/``. ``on_result`` is called with each result as it
    finishes; ``progress`` shows a progress bar on stderr (samples done, best robustness, ETA; None:
    only when stderr is a terminal).
    """
    batch = list(samples)
    if not batch:
        raise ConfigurationError("samples", batch, "at least one sample")
    with Campaign(
        simulate,
        requirement,
        fidelity=fidelity,
        seed=seed,
        executor=executor,
        ray_address=ray_address,
        timeout=timeout,
        max_retries=max_retries,
        output=output,
        progress=progress,
        on_result=on_result,
    ) as campaign:
        campaign.evaluate(batch)
        return campaign.result()
