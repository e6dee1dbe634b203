"""Campaigns: a batch of samples evaluated as simulations, in a local process pool or on Ray.

::

    from multicosim.search.campaign import latin_hypercube, run_campaign

    def simulate(sample, fidelity, seed):           # one simulation -> its trajectory
        with rover.Rover(fidelity=fidelity, seed=seed).start() as simulation:
            return simulation.controller.send(rover.Mission(speed=sample["speed"]))

    design = latin_hypercube({"speed": (1.0, 10.0)}, 200, seed=1)
    result = run_campaign(simulate, "always (z > -0.1)", design, output="campaign")
    result.violations, result.rate_per_minute   # campaign/results.csv, campaign/traces/...

Each sample runs ``simulate(sample, fidelity, seed)`` in a worker; its seed derives from the
campaign seed and the sample's index (:func:`sample_seed`), never from the order in which
samples finish, so a campaign gives the same results on any executor. A worker returns the
requirement's robustness, a summary of the trajectory and, for a sample that violates the
requirement, fails or times out, its MCAP trace. Results stream back as they finish
(``on_result``, a progress bar on a terminal) and are written as ``results.csv`` (and
``results.parquet`` where pyarrow is installed) with the traces under ``output``.

Executors: ``"process"`` (default; a ``concurrent.futures`` pool of forkserver processes) and
``"ray"`` / ``ray_address=...`` (Ray tasks; each simulation uses the process backend on its
worker). A worker that dies is retried ``max_retries`` times and reported in
``CampaignResult.retries``; a sample still running at ``timeout`` is cancelled; Ctrl-C stops
every task, writes what finished and raises :class:`CampaignInterrupted` carrying it.
:class:`Campaign` keeps an executor open for optimizers that ask for batches.
"""

from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import csv
import dataclasses
import functools
import inspect
import logging
import math
import multiprocessing
import os
import signal
import socket
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from types import FrameType, ModuleType, TracebackType
from typing import Any, Protocol

import msgspec
import numpy as np

from ..core.deps import require
from ..core.errors import ConfigurationError, MulticosimError
from ..core.fidelity import check_fidelity
from .progress import ProgressBar, wanted
from .requirements import Evaluation, Requirement

__all__ = [
    "STATUSES",
    "Campaign",
    "CampaignInterrupted",
    "CampaignResult",
    "ExecutorSpec",
    "ProcessExecutor",
    "RayExecutor",
    "RetryEvent",
    "SampleResult",
    "Simulate",
    "check_simulate",
    "from_strategy",
    "latin_hypercube",
    "random_design",
    "run_campaign",
    "sample_seed",
    "summarize",
]

log = logging.getLogger(__name__)

# The one callback shape of campaigns, falsify and taliro:
# simulate(sample, fidelity, seed) -> a trajectory Requirement.evaluate accepts
Simulate = Callable[[Any, str, int], object]

STATUSES = ("ok", "violated", "error", "timeout", "lost")
# How long past its timeout a sample may run before the driver kills its worker: the
# worker's own alarm normally ends it at the timeout; this catches code that never returns
# to the interpreter (a C call that blocks).
_GRACE = 5.0
_POLL = 0.2


def check_simulate(simulate: object, field: str = "simulate") -> Simulate:
    """Return ``simulate`` if it can be called as ``simulate(sample, fidelity, seed)``."""
    allowed = "a function simulate(sample, fidelity, seed) returning a trajectory"
    if not callable(simulate):
        raise ConfigurationError(field, simulate, allowed)
    try:
        signature = inspect.signature(simulate)
    except (TypeError, ValueError):
        return simulate  # a builtin or extension callable: nothing to check
    try:
        signature.bind(None, "low", 0)
    except TypeError:
        raise ConfigurationError(field, simulate, f"{allowed} (it takes {signature})") from None
    return simulate


def sample_seed(campaign_seed: int, index: int) -> int:
    """The seed of sample ``index``: a function of the campaign seed and the index only."""
    state = np.random.SeedSequence(campaign_seed, spawn_key=(index,)).generate_state(1)
    return int(state[0])


# -- designs ---------------------------------------------------------------------------------


def _check_count(n: object) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigurationError("n", n, "a positive number of samples")
    return n


def _check_seed(seed: object) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigurationError("seed", seed, "a non-negative integer")
    return seed


def _check_ranges(ranges: Mapping[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    if not isinstance(ranges, Mapping) or not ranges:
        raise ConfigurationError("ranges", ranges, "a mapping of at least one name to (low, high)")
    out: dict[str, tuple[float, float]] = {}
    for name, bounds in ranges.items():
        ok = (
            isinstance(bounds, tuple | list)
            and len(bounds) == 2
            and all(isinstance(b, int | float) and not isinstance(b, bool) for b in bounds)
            and all(math.isfinite(b) for b in bounds)
            and bounds[0] < bounds[1]
        )
        if not ok:
            raise ConfigurationError(
                f"ranges[{name!r}]", bounds, "(low, high) with finite low < high"
            )
        out[str(name)] = (float(bounds[0]), float(bounds[1]))
    return out


def random_design(
    ranges: Mapping[str, tuple[float, float]], n: int, *, seed: int = 0
) -> list[dict[str, float]]:
    """``n`` samples drawn uniformly from the box ``ranges`` (name -> (low, high))."""
    box, n, seed = _check_ranges(ranges), _check_count(n), _check_seed(seed)
    rng = np.random.default_rng(seed)
    columns = {name: rng.uniform(lo, hi, n) for name, (lo, hi) in box.items()}
    return [{name: float(col[i]) for name, col in columns.items()} for i in range(n)]


def latin_hypercube(
    ranges: Mapping[str, tuple[float, float]], n: int, *, seed: int = 0
) -> list[dict[str, float]]:
    """``n`` samples of a Latin hypercube over ``ranges``: each range cut in ``n`` strata, one
    sample in each stratum of every input."""
    box, n, seed = _check_ranges(ranges), _check_count(n), _check_seed(seed)
    rng = np.random.default_rng(seed)
    columns = {}
    for name, (lo, hi) in box.items():
        strata = (rng.permutation(n) + rng.random(n)) / n
        columns[name] = lo + strata * (hi - lo)
    return [{name: float(col[i]) for name, col in columns.items()} for i in range(n)]


def from_strategy(strategy: Any, n: int, *, seed: int = 0) -> list[Any]:
    """Up to ``n`` examples of a Hypothesis strategy, the same ones for the same seed.

    Fewer come back when the strategy has fewer distinct examples.
    """
    n, seed = _check_count(n), _check_seed(seed)
    require("hypothesis", "hypothesis")
    import hypothesis

    if not isinstance(strategy, hypothesis.strategies.SearchStrategy):
        raise ConfigurationError("strategy", strategy, "a Hypothesis strategy")
    drawn: list[Any] = []

    # A throwaway @given test is Hypothesis's seedable way to draw examples (.example() is not).
    @hypothesis.settings(
        max_examples=n,
        database=None,
        deadline=None,
        phases=[hypothesis.Phase.generate],
        suppress_health_check=list(hypothesis.HealthCheck),
    )
    @hypothesis.seed(seed)
    @hypothesis.given(strategy)
    def collect(example: Any) -> None:
        drawn.append(example)

    collect()
    return drawn[:n]


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


# -- what a worker runs ----------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class _RequirementSpec:
    """A requirement as its constructor arguments: rtamt monitors do not pickle."""

    formula: str
    semantics: str
    derived: tuple[tuple[str, Any], ...]
    name: str

    @classmethod
    def of(cls, requirement: Requirement) -> _RequirementSpec:
        return cls(
            requirement.formula,
            requirement.semantics,
            tuple(requirement.derived.items()),
            requirement.name,
        )

    def build(self) -> Requirement:
        return _build_requirement(self)


@functools.lru_cache(maxsize=16)
def _build_requirement(spec: _RequirementSpec) -> Requirement:
    # Parsed once per worker process, not once per sample.
    return Requirement(
        spec.formula,
        semantics=spec.semantics,  # type: ignore[arg-type]
        derived=dict(spec.derived),
        name=spec.name,
    )


@dataclasses.dataclass(frozen=True)
class _Task:
    index: int
    seed: int
    sample: Any
    fidelity: str
    simulate: Simulate
    requirement: _RequirementSpec
    timeout: float
    record: bool


@dataclasses.dataclass(frozen=True)
class _Outcome:
    index: int
    status: str
    robustness: float
    summary: dict[str, Any]
    evaluation: Evaluation | None
    error: str
    wall_time: float
    worker: str
    traces: dict[str, bytes]


class _SampleTimeout(BaseException):
    """Raised in the worker at the timeout; a BaseException so ``except Exception`` in
    simulation code does not swallow it."""


@contextlib.contextmanager
def _alarm(seconds: float) -> Any:
    if threading.current_thread() is not threading.main_thread():
        yield  # signals reach the main thread only: the driver's backstop applies
        return

    def expire(signum: int, frame: FrameType | None) -> None:
        raise _SampleTimeout

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def summarize(trajectory: object) -> dict[str, Any]:
    """A flat summary of a trajectory: its scalar fields, length, duration and each signal's
    minimum, maximum and final value."""
    from .requirements import signals_of

    out: dict[str, Any] = {}
    if isinstance(trajectory, msgspec.Struct):
        fields: Iterable[str] = trajectory.__struct_fields__
    elif dataclasses.is_dataclass(trajectory) and not isinstance(trajectory, type):
        fields = [f.name for f in dataclasses.fields(trajectory)]
    else:
        fields = ()
    for name in fields:
        value = getattr(trajectory, name)
        if isinstance(value, bool | int | float | str):
            out[name] = value
    signals = signals_of(trajectory)
    out["samples"] = len(signals)
    out["duration"] = float(signals.times[-1] - signals.times[0])
    for name, column in signals.columns.items():
        out[f"{name}_min"] = float(np.min(column))
        out[f"{name}_max"] = float(np.max(column))
        out[f"{name}_final"] = float(column[-1])
    return out


def _run_task(task: _Task) -> _Outcome:
    """Run one sample (in a worker): simulate, evaluate, keep the trace of a failure."""
    from .. import trace

    started = time.perf_counter()
    session = trace.TestTrace(
        # FreshSimulations reads fidelity and seed from here: simulate code that uses it
        # gets the sample's seed without being told.
        metadata={
            "fidelity": task.fidelity,
            "seed": task.seed,
            "campaign_index": task.index,
            "failing_example": repr(task.sample),
            "requirement": task.requirement.formula,
        },
        record=task.record,
    )
    status, robustness, error = "error", math.nan, ""
    summary: dict[str, Any] = {}
    evaluation: Evaluation | None = None
    try:
        requirement = task.requirement.build()
        with trace.activate(session), _alarm(task.timeout):
            trajectory = task.simulate(task.sample, task.fidelity, task.seed)
            evaluation = requirement.evaluate(trajectory)
        summary = summarize(trajectory)
        robustness = evaluation.robustness
        status = "ok" if evaluation.satisfied else "violated"
    except _SampleTimeout:
        status, error = "timeout", f"cancelled at its timeout of {task.timeout:g} s"
    except Exception as exc:
        status, error = "error", f"{type(exc).__name__}: {exc}"
    traces: dict[str, bytes] = {}
    if task.record and status != "ok":
        traces = _trace_bytes(session)
    return _Outcome(
        index=task.index,
        status=status,
        robustness=robustness,
        summary=summary,
        evaluation=evaluation,
        error=error,
        wall_time=time.perf_counter() - started,
        worker=f"{socket.gethostname()}:{os.getpid()}",
        traces=traces,
    )


def _trace_bytes(session: Any) -> dict[str, bytes]:
    # The bytes travel back to the driver: on a cluster the worker's disk is not the user's.
    try:
        with tempfile.TemporaryDirectory(prefix="mcs-campaign-") as tmp:
            return {p.name: p.read_bytes() for p in session.save(tmp, plot=False)}
    except Exception as exc:  # a trace is a diagnosis aid: never lose the result over it
        log.warning("could not save the trace of a campaign sample: %s", exc)
        return {}


def _worker_init() -> None:
    # Ctrl-C in a terminal reaches the whole process group: the driver alone handles it (and
    # stops the workers), so that no worker dies with a KeyboardInterrupt traceback.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


# -- executors -------------------------------------------------------------------------------


class _WorkerLost(Exception):
    """The worker running a task died (or its node did)."""


class _TaskFailed(Exception):
    """The task could not run at all (its function did not unpickle on the worker, say)."""


class _Backend(Protocol):
    name: str
    capacity: int

    def submit(self, task: _Task) -> Any: ...
    def wait(self, handles: Sequence[Any], timeout: float) -> list[Any]: ...
    def outcome(self, handle: Any) -> _Outcome: ...
    def kill(self, handles: Sequence[Any]) -> None: ...
    def close(self) -> None: ...


class ProcessExecutor:
    """Run samples in a local pool of ``workers`` processes (default: one per core).

    ``context`` is the multiprocessing start method: ``forkserver`` (default) or ``spawn``;
    fork is refused because a forked ZeroMQ context is unsafe.
    """

    name = "process"

    def __init__(self, workers: int | None = None, *, context: str = "forkserver") -> None:
        if workers is not None and (
            isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
        ):
            raise ConfigurationError("workers", workers, "a positive number of processes")
        if context not in ("forkserver", "spawn"):
            raise ConfigurationError("context", context, "'forkserver' or 'spawn'")
        self.workers = workers or os.cpu_count() or 1
        self.context = context

    def __repr__(self) -> str:
        return f"ProcessExecutor(workers={self.workers}, context={self.context!r})"

    def _open(self) -> _Backend:
        return _PoolBackend(self.workers, self.context)


class _PoolBackend:
    name = "process"

    def __init__(self, workers: int, context: str) -> None:
        self.capacity = workers
        self._workers = workers
        self._context = multiprocessing.get_context(context)
        self._pool: concurrent.futures.ProcessPoolExecutor | None = None
        # Which pool ran a future: a broken pool must not take its replacement down with it.
        self._owner: dict[concurrent.futures.Future[_Outcome], Any] = {}

    def submit(self, task: _Task) -> concurrent.futures.Future[_Outcome]:
        if self._pool is None:
            self._pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=self._workers, mp_context=self._context, initializer=_worker_init
            )
        future = self._pool.submit(_run_task, task)
        self._owner[future] = self._pool
        return future

    def wait(self, handles: Sequence[Any], timeout: float) -> list[Any]:
        done, _ = concurrent.futures.wait(
            handles, timeout=timeout, return_when=concurrent.futures.FIRST_COMPLETED
        )
        return list(done)

    def outcome(self, handle: Any) -> _Outcome:
        pool = self._owner.pop(handle, None)
        try:
            result: _Outcome = handle.result()
            return result
        except BrokenProcessPool as exc:
            self._discard(pool)
            raise _WorkerLost("a worker process died (the pool broke)") from exc
        except concurrent.futures.CancelledError as exc:
            raise _WorkerLost("cancelled with its worker") from exc
        except Exception as exc:  # pickling the task or its result failed
            raise _TaskFailed(f"{type(exc).__name__}: {exc}") from exc

    def _discard(self, pool: concurrent.futures.ProcessPoolExecutor | None) -> None:
        current = self._pool
        if pool is None or pool is not current:
            return  # an older pool: its replacement is running other tasks
        self._pool = None
        pool.shutdown(wait=False, cancel_futures=True)

    def kill(self, handles: Sequence[Any]) -> None:
        pools = {id(p): p for h in handles if (p := self._owner.get(h)) is not None}
        for pool in pools.values():
            # No public way to stop a running task: end the processes, and with them the pool.
            processes = list(getattr(pool, "_processes", {}).values())
            for process in processes:
                with contextlib.suppress(OSError):
                    process.kill()
            for process in processes:
                process.join(timeout=10)
            self._discard(pool)

    def close(self) -> None:
        pool = self._pool
        self._pool = None
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


class RayExecutor:
    """Run samples as Ray tasks on a cluster (each uses the process backend on its worker).

    ``address`` is what ``ray.init`` takes (``"auto"``, ``"ray://head:10001"``, ...); None
    uses the running Ray connection, else starts a local cluster bound to loopback.
    ``init`` adds keyword arguments for ``ray.init``. Ray connects on first use and stays
    connected until :meth:`shutdown` (which disconnects only what this object connected).
    The simulate function must be importable on the workers (or defined in ``__main__``);
    ship code to a remote cluster with a ``runtime_env`` in ``init``.
    """

    name = "ray"

    def __init__(
        self,
        address: str | None = None,
        *,
        init: Mapping[str, Any] | None = None,
        max_in_flight: int | None = None,
    ) -> None:
        if address is not None and (not isinstance(address, str) or not address.strip()):
            raise ConfigurationError("ray_address", address, "a Ray address or None")
        if max_in_flight is not None and (
            isinstance(max_in_flight, bool)
            or not isinstance(max_in_flight, int)
            or max_in_flight < 1
        ):
            raise ConfigurationError("max_in_flight", max_in_flight, "a positive number")
        self.address = address.strip() if address is not None else None
        self.init = dict(init or {})
        self.max_in_flight = max_in_flight
        self._connected = False

    def __repr__(self) -> str:
        return f"RayExecutor(address={self.address!r})"

    def connect(self) -> ModuleType:
        """Connect to (or start) the cluster if not yet connected; return the ray module."""
        ray = require("ray", "ray")
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"address": self.address, "log_to_driver": False}
            if self.address in (None, "local"):
                kwargs.update(include_dashboard=False, _node_ip_address="127.0.0.1")
            kwargs.update(self.init)
            ray.init(**kwargs)
            self._connected = True
        return ray

    def shutdown(self) -> None:
        """Disconnect from Ray (stopping a local cluster) if this executor connected."""
        if self._connected:
            self._connected = False
            import ray

            ray.shutdown()

    def _open(self) -> _Backend:
        ray = self.connect()
        cpus = int(ray.cluster_resources().get("CPU", 1)) or 1
        # A little more than the cluster runs at once keeps every worker fed between results.
        return _RayBackend(ray, self.max_in_flight or 2 * cpus)


class _RayBackend:
    name = "ray"

    def __init__(self, ray: ModuleType, capacity: int) -> None:
        self.capacity = capacity
        self._ray = ray
        # Retries are ours, not Ray's: counted per sample and reported.
        self._remote = ray.remote(_run_task).options(max_retries=0, num_cpus=1)
        errors = ray.exceptions
        self._lost = tuple(
            getattr(errors, name)
            for name in (
                "WorkerCrashedError",
                "NodeDiedError",
                "LocalRayletDiedError",
                "ObjectLostError",
                "OwnerDiedError",
                "ActorDiedError",
            )
            if hasattr(errors, name)
        )

    def submit(self, task: _Task) -> Any:
        return self._remote.remote(task)

    def wait(self, handles: Sequence[Any], timeout: float) -> list[Any]:
        ready, _ = self._ray.wait(list(handles), num_returns=1, timeout=timeout)
        return list(ready)

    def outcome(self, handle: Any) -> _Outcome:
        errors = self._ray.exceptions
        try:
            result: _Outcome = self._ray.get(handle)
            return result
        except self._lost as exc:
            raise _WorkerLost(f"{type(exc).__name__}: the worker died") from exc
        except errors.TaskCancelledError as exc:
            raise _WorkerLost("cancelled") from exc
        except errors.RayError as exc:
            first = str(exc).strip().splitlines()
            raise _TaskFailed(f"{type(exc).__name__}: {first[-1] if first else ''}") from exc

    def kill(self, handles: Sequence[Any]) -> None:
        for handle in handles:
            with contextlib.suppress(Exception):
                self._ray.cancel(handle, force=True)
        # Wait (bounded) for the cancellations to land: nothing may run after we return.
        with contextlib.suppress(Exception):
            self._ray.wait(list(handles), num_returns=len(handles), timeout=10)

    def close(self) -> None:
        pass


ExecutorSpec = str | ProcessExecutor | RayExecutor | None


def _executor(executor: ExecutorSpec, ray_address: str | None) -> ProcessExecutor | RayExecutor:
    if isinstance(executor, ProcessExecutor | RayExecutor):
        if ray_address is not None:
            raise ConfigurationError("ray_address", ray_address, "None with an executor object")
        return executor
    if executor is None:
        executor = "ray" if ray_address is not None else "process"
    if executor == "process":
        if ray_address is not None:
            raise ConfigurationError("ray_address", ray_address, "None with executor='process'")
        return ProcessExecutor()
    if executor == "ray":
        return RayExecutor(ray_address)
    raise ConfigurationError(
        "executor", executor, "'process', 'ray', a ProcessExecutor or a RayExecutor"
    )


# -- results ---------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SampleResult:
    """The outcome of one sample.

    ``status`` is one of :data:`STATUSES`: ``ok`` (requirement holds), ``violated``,
    ``error`` (simulate raised; see ``error``), ``timeout`` or ``lost`` (its worker died more
    often than the campaign retries). ``attempts`` counts runs (> 1: retried);
    ``trace`` holds the saved MCAP trace of a sample that did not pass.
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
    """A campaign kept open across batches (an optimizer's ask/tell loop)::

        with Campaign(simulate, requirement, executor="ray") as campaign:
            for batch in optimizer:                   # any number of batches
                results = campaign.evaluate(batch)    # in the batch's order
        campaign.result()

    Sample indices, hence seeds, continue from one batch to the next. Arguments are those of
    :func:`run_campaign`.
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
        self.seed = _check_seed(seed)
        if (
            isinstance(timeout, bool)
            or not isinstance(timeout, int | float)
            or not math.isfinite(timeout)
            or timeout <= 0
        ):
            raise ConfigurationError("timeout", timeout, "a positive number of seconds")
        if isinstance(max_retries, bool) or not isinstance(max_retries, int) or max_retries < 0:
            raise ConfigurationError("max_retries", max_retries, "a non-negative integer")
        self._executor = _executor(executor, ray_address)
        # The caller's executor object is theirs to shut down; one we made is ours.
        self._own_executor = not isinstance(executor, ProcessExecutor | RayExecutor)
        req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)
        self.requirement = req
        self._spec = _RequirementSpec.of(req)
        self.simulate = simulate
        self.fidelity = fidelity
        self.timeout = float(timeout)
        self.max_retries = max_retries
        self.output = Path(output) if output is not None else None
        self.on_result = on_result
        self._progress = ProgressBar(wanted(progress), 0, f"campaign [{self._executor.name}]")
        self._backend: _Backend | None = None
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
            self._backend = self._executor._open()
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

    def _task(self, flight: _Flight) -> _Task:
        return _Task(
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
        self, backend: _Backend, handle: Any, flight: _Flight, queue: collections.deque[_Flight]
    ) -> None:
        try:
            outcome = backend.outcome(handle)
        except _WorkerLost as exc:
            self._retries.append(RetryEvent(flight.index, flight.attempt, str(exc)))
            if flight.attempt <= self.max_retries:
                log.warning("campaign sample %d lost its worker (%s): retrying", flight.index, exc)
                # To the front: a retried sample should not wait behind the whole campaign.
                queue.appendleft(_Flight(flight.index, flight.sample, flight.attempt + 1, 0.0))
                return
            self._finish(flight, "lost", f"its worker died {flight.attempt} times: {exc}")
            return
        except _TaskFailed as exc:
            self._finish(flight, "error", str(exc))
            return
        traces = self._save_traces(outcome)
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

    def _cancel_overdue(self, backend: _Backend, flying: dict[Any, _Flight]) -> None:
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

    def _save_traces(self, outcome: _Outcome) -> tuple[Path, ...]:
        if self.output is None or not outcome.traces:
            return ()
        directory = self.output / "traces" / f"sample-{outcome.index:05d}"
        directory.mkdir(parents=True, exist_ok=True)
        saved = []
        for name, data in sorted(outcome.traces.items()):
            path = directory / name
            path.write_bytes(data)
            saved.append(path)
        return tuple(saved)

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
        self.output.mkdir(parents=True, exist_ok=True)
        rows = [_row(self._results[i]) for i in sorted(self._results)]
        header = list(dict.fromkeys(key for row in rows for key in row))
        csv_path = self.output / "results.csv"
        with csv_path.open("w", newline="") as stream:
            writer = csv.DictWriter(stream, fieldnames=header, restval="")
            writer.writeheader()
            writer.writerows(rows)
        parquet_path = None
        with contextlib.suppress(ImportError):
            import importlib

            pa = importlib.import_module("pyarrow")
            pq = importlib.import_module("pyarrow.parquet")
            parquet_path = self.output / "results.parquet"
            pq.write_table(pa.Table.from_pylist(rows), parquet_path)
        self._written = (csv_path, parquet_path)
        return self._written


def _flatten(sample: Any) -> dict[str, Any]:
    if isinstance(sample, Mapping):
        return {str(k): v for k, v in sample.items()}
    if isinstance(sample, msgspec.Struct):
        return {f: getattr(sample, f) for f in sample.__struct_fields__}
    if dataclasses.is_dataclass(sample) and not isinstance(sample, type):
        return {f.name: getattr(sample, f.name) for f in dataclasses.fields(sample)}
    return {"": sample}


def _cell(value: Any) -> Any:
    return value if isinstance(value, bool | int | float | str) or value is None else repr(value)


def _row(result: SampleResult) -> dict[str, Any]:
    row: dict[str, Any] = {
        "index": result.index,
        "seed": result.seed,
        "status": result.status,
        "robustness": result.robustness,
        "attempts": result.attempts,
        "wall_time": result.wall_time,
        "worker": result.worker,
        "error": result.error,
        "trace": ";".join(str(p) for p in result.trace),
    }
    for key, value in _flatten(result.sample).items():
        row["sample" + (f".{key}" if key else "")] = _cell(value)
    for key, value in result.summary.items():
        row[f"summary.{key}"] = _cell(value)
    return row


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
    :class:`ProcessExecutor` or a :class:`RayExecutor` (``ray_address`` implies Ray).
    ``timeout`` (s) cancels a sample that runs longer; a sample whose worker dies is re-run
    up to ``max_retries`` times. With ``output``, results go to ``output/results.csv`` and
    the traces of samples that did not pass to ``output/traces/``. ``on_result`` is called
    with each result as it finishes; ``progress`` shows a progress bar on stderr (samples done,
    best robustness, ETA; None: only when stderr is a terminal).
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
