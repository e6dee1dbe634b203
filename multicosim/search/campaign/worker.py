"""What a campaign worker runs: one sample as a simulation, evaluated, its trace kept on failure.

The executors (``executors``) ship a ``Task`` to a worker by pickle and get an
``Outcome`` back, so both stay importable here, at a stable path, for the workers to
unpickle; ``run_task`` is the function they call. The process pool ships the task by
cloudpickle (``pickled``, ``run_pickled``), as Ray does: a ``simulate`` (or a sample
type, a derived signal) defined in ``__main__`` travels by value, so that a notebook's or
``python -``'s functions run in workers that cannot import them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import math
import os
import signal
import socket
import tempfile
import threading
import time
from collections.abc import Iterable
from types import FrameType
from typing import Any

import msgspec
import numpy as np

from ..requirements import Evaluation, Requirement
from .simulate import Simulate

__all__ = [
    "Outcome",
    "RequirementSpec",
    "Task",
    "pickled",
    "run_pickled",
    "run_task",
    "summarize",
    "worker_init",
]

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class RequirementSpec:
    """A requirement as its constructor arguments: rtamt monitors do not pickle."""

    formula: str
    semantics: str
    derived: tuple[tuple[str, Any], ...]
    name: str

    @classmethod
    def of(cls, requirement: Requirement) -> RequirementSpec:
        """The spec that builds ``requirement`` again."""
        return cls(
            requirement.formula,
            requirement.semantics,
            tuple(requirement.derived.items()),
            requirement.name,
        )

    def build(self) -> Requirement:
        """The requirement, parsed once per worker process."""
        return _build_requirement(self)


@functools.lru_cache(maxsize=16)
def _build_requirement(spec: RequirementSpec) -> Requirement:
    # Parsed once per worker process, not once per sample.
    return Requirement(
        spec.formula,
        semantics=spec.semantics,  # type: ignore[arg-type]
        derived=dict(spec.derived),
        name=spec.name,
    )


@dataclasses.dataclass(frozen=True)
class Task:
    """One sample to run in a worker, with everything the worker needs to run it."""

    index: int
    seed: int
    sample: Any
    fidelity: str
    simulate: Simulate
    requirement: RequirementSpec
    timeout: float
    record: bool


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What a worker sends back for a task: status, robustness, summary and failure traces."""

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
    from ..requirements import signals_of

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


def run_task(task: Task) -> Outcome:
    """Run one sample (in a worker): simulate, evaluate, keep the trace of a failure."""
    from ... import trace

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
    return Outcome(
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


def pickled(task: Task) -> bytes:
    """``task`` as cloudpickle bytes: what its worker's ``__main__`` defines goes by value."""
    import cloudpickle

    payload: bytes = cloudpickle.dumps(task)
    return payload


def run_pickled(payload: bytes) -> Outcome:
    """Run the task ``pickled`` made (in a worker)."""
    import pickle

    task: Task = pickle.loads(payload)
    return run_task(task)


def worker_init() -> None:
    """Initialise a pool worker: leave Ctrl-C to the driver."""
    # Ctrl-C in a terminal reaches the whole process group: the driver alone handles it (and
    # stops the workers), so that no worker dies with a KeyboardInterrupt traceback.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
