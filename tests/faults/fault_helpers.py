"""Injecting faults into running simulations, and timing how long they take to be reported.

Times are ``time.monotonic()``: one clock for every process of the machine, containers
included, so a component's own stamp (``[monotonic M]``, printed by
``multicosim.testing.Faulty``) and the test's reading of the error compare directly.
"""

from __future__ import annotations

import json
import logging
import os
import re
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import pytest

import multicosim as mcs

MARGIN = 10.0
"""s: what a loaded two-core machine may add to a fault's own timeout before its error."""

RESULTS = Path(__file__).resolve().parents[2] / "bench" / "results" / "faults"
"""Where each fault's record goes (``FAULT.json``) when ``MCS_RECORD_FAULTS=1``: a test run
changes no file of the checkout unless asked to."""

log = logging.getLogger(__name__)


E = TypeVar("E", bound=BaseException)


def failing(call: Callable[[], object], expected: type[E]) -> tuple[E, float]:
    """Run ``call``, which must raise ``expected``: the error, and the time it came."""
    try:
        call()
    except expected as error:
        return error, time.monotonic()
    pytest.fail(f"no {expected.__name__}: the fault went unreported")


STAMP = re.compile(r"\[monotonic (\d+\.\d+)\]")


def stamped(text: str) -> float:
    """The last ``[monotonic M]`` stamp in a component's output (when it faulted)."""
    found = STAMP.findall(text)
    assert found, f"no [monotonic ...] stamp in:\n{text}"
    return float(found[-1])


class Trigger:
    """An in-process participant that injects a fault once ``when(ctx)`` holds.

    It steps in lockstep with the rest (every ``period`` of simulated time), so the fault
    lands at a simulated instant; ``fault_at`` is the wall clock just before ``inject()``.
    ``topic`` (with its message ``type``) is subscribed to for ``when`` to read.
    """

    def __init__(
        self,
        when: Callable[[mcs.StepContext, Any], bool],
        inject: Callable[[], object],
        *,
        period: float = 0.05,
        topic: str | None = None,
        type: type[Any] | None = None,
    ) -> None:
        self.period = period
        self.when = when
        self.inject = inject
        self.topic = topic
        self.type = type
        self.subscription: Any = None
        self.fault_at: float | None = None

    def setup(self, ctx: mcs.StepContext) -> None:
        """Subscribe to ``topic``, if any."""
        if self.topic is not None and self.type is not None:
            self.subscription = ctx.subscribe(self.topic, self.type)

    def step(self, ctx: mcs.StepContext) -> None:
        """Inject the fault the first time ``when`` holds."""
        if self.fault_at is None and self.when(ctx, self.subscription):
            self.fault_at = time.monotonic()
            self.inject()


def at_time(seconds: float) -> Callable[[mcs.StepContext, Any], bool]:
    """A trigger condition: simulated time has reached ``seconds``."""
    return lambda ctx, _: ctx.time >= seconds


def airborne(height: float) -> Callable[[mcs.StepContext, Any], bool]:
    """A trigger condition: the world's truth (``Truth``) is ``height`` m above home."""
    return lambda ctx, truth: (
        truth is not None and truth.latest is not None and (truth.latest.alt >= height)
    )


class Watcher(threading.Thread):
    """A thread that injects a fault once ``when()`` holds (checked every 5 ms).

    For faults that must land while the lockstep is busy inside a component's step, when
    no participant can run. ``fault_at`` is the wall clock just before ``inject()``; an
    error of either is raised again by :meth:`finish`.
    """

    def __init__(
        self, when: Callable[[], bool], inject: Callable[[], object], timeout: float = 120.0
    ) -> None:
        super().__init__(name="fault-watcher", daemon=True)
        self.when = when
        self.inject = inject
        self.timeout = timeout
        self.fault_at: float | None = None
        self.error: BaseException | None = None
        self._stop_event = threading.Event()

    def run(self) -> None:
        deadline = time.monotonic() + self.timeout
        try:
            while not self.when():
                if self._stop_event.wait(0.005) or time.monotonic() > deadline:
                    return
            self.fault_at = time.monotonic()
            self.inject()
        except BaseException as exc:
            self.error = exc

    def finish(self) -> float:
        """Stop watching; the time the fault was injected (it must have been)."""
        self._stop_event.set()
        self.join(10.0)
        if self.error is not None:
            raise self.error
        assert self.fault_at is not None, "the fault was never injected"
        return self.fault_at


class Detections:
    """Records a fault's detection time for docs/reliability.md and checks it against its bound."""

    def __init__(self, request: pytest.FixtureRequest) -> None:
        self._request = request

    def record(
        self, fault: str, fault_at: float, error_at: float, timeout: float, error: BaseException
    ) -> float:
        """Note that ``error`` reported ``fault`` ``error_at - fault_at`` s after it happened.

        ``timeout`` is the fault's own bound (a step timeout; 0 for a fault seen at once):
        the error must come within it plus MARGIN. Returns the detection time.
        """
        seconds = error_at - fault_at
        message = str(error).split("\n--- last output ---")[0]
        self._write(fault, round(seconds, 3), timeout, f"{type(error).__name__}: {message}")
        self._request.node.user_properties.append(("mcs_detection_s", f"{seconds:.3f}"))
        print(f"{fault}: detected after {seconds:.3f} s ({message})")
        assert 0.0 <= seconds <= timeout + MARGIN, (
            f"{fault}: detected after {seconds:.2f} s, not within {timeout:g} s + {MARGIN:g} s"
        )
        return seconds

    def unaffected(self, fault: str, outcome: str) -> None:
        """Note that ``fault`` is no failure of the run: ``outcome`` says what happens."""
        self._write(fault, None, None, outcome)

    def _write(
        self, fault: str, seconds: float | None, timeout: float | None, outcome: str
    ) -> None:
        record = {
            "fault": fault,
            "detected_s": seconds,
            "timeout_s": timeout,
            "outcome": outcome,
            "test": self._request.node.nodeid,
            "line": self._request.node.location[1],  # the table lists faults in file order
            "load_average": round(os.getloadavg()[0], 2),
            "cores": os.cpu_count(),
        }
        if os.environ.get("MCS_RECORD_FAULTS") != "1":
            return
        # Paths of this machine's temporary directories say nothing about the fault.
        record["outcome"] = re.sub(r"'/[^']*/([^/']+)'", r"'.../\1'", outcome)
        slug = re.sub(r"[^A-Za-z0-9]+", "-", fault).strip("-").lower()
        try:
            RESULTS.mkdir(parents=True, exist_ok=True)
            (RESULTS / f"{slug}.json").write_text(json.dumps(record, indent=2) + "\n")
        except OSError as exc:  # a read-only checkout: the figure is still in the report
            log.warning("could not record the detection time of %s: %s", fault, exc)
