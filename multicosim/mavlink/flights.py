"""Several ground stations flying at once on one clock: a fleet's missions.

A ground station (``GroundStation``) flies one vehicle's mission as a procedure
that steps the clock itself. To fly several vehicles at once, ``fly_together`` runs each
one's procedure in a lane of its own, a thread used as a coroutine: the firmware that flies
them all hands its context to one lane at a time, in the fleet's order, until that lane asks
for the next step; once every lane has, it steps the clock and starts again. Only one lane
ever runs, always in the same order, so a fleet's flight is as deterministic as one
vehicle's.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Generic, TypeVar

from ..core.errors import MulticosimError
from ..runtime.context import FirmwareContext, Subscription

__all__ = ["LaneContext", "fly_together"]

R = TypeVar("R")
T = TypeVar("T")

_SLICE = 0.1  # s: how long a hand-over waits before it looks again (interrupts land there)


class _Stopped(BaseException):
    """Ends a lane whose flight was called off (another lane failed, the run stopped)."""


class LaneContext:
    """What one lane's procedure sees of the firmware's context: its time, its topics, its
    publications, and ``step`` (which hands over to the next lane)."""

    def __init__(self, main: FirmwareContext, name: str, step: Callable[[], None]) -> None:
        self._main = main
        self._step = step
        self.name = f"{main.name}/{name}"

    @property
    def time(self) -> float:
        """Current simulated time in seconds."""
        return self._main.time

    @property
    def time_ns(self) -> int:
        """Current simulated time in nanoseconds."""
        return self._main.time_ns

    @property
    def period(self) -> float:
        """The firmware's period (s): what a ``step`` lasts."""
        return self._main.period

    def publish(self, topic: str, msg: object) -> None:
        """Publish ``msg`` on ``topic`` (through the firmware, in this instant)."""
        self._main.publish(topic, msg)

    def subscribe(self, topic: str, tp: type[T]) -> Subscription[T]:
        """Receive ``topic`` (through the firmware)."""
        return self._main.subscribe(topic, tp)

    def step(self, duration: float | None = None) -> None:
        """Wait for the next step of the clock (one period; no other duration)."""
        if duration is not None and duration != self._main.period:
            raise MulticosimError(
                f"{self.name}: a lane steps one period ({self._main.period:g} s) at a time"
            )
        self._step()


class _Lane(Generic[R]):
    """One procedure in a thread of its own, run a step at a time."""

    def __init__(self, name: str, run: Callable[[LaneContext], R], main: FirmwareContext) -> None:
        self.name = name
        self.result: R | None = None
        self.error: BaseException | None = None
        self.done = False
        self._run = run
        # Two locks held by nobody in particular, as binary semaphores: half the cost of a
        # hand-over through threading.Semaphore, which every lane pays twice a step.
        self._go = threading.Lock()
        self._back = threading.Lock()
        self._go.acquire()
        self._back.acquire()
        self._stop = False
        self.ctx = LaneContext(main, name, self.yield_to_main)
        self._thread = threading.Thread(target=self._body, name=f"lane-{name}", daemon=True)
        self._thread.start()

    def _body(self) -> None:
        self._go.acquire()
        try:
            if not self._stop:
                self.result = self._run(self.ctx)
        except _Stopped:
            pass
        except BaseException as exc:
            self.error = exc
        finally:
            self.done = True
            self._back.release()

    def yield_to_main(self) -> None:
        """From the lane: hand over until the main loop resumes it."""
        self._back.release()
        self._go.acquire()
        if self._stop:
            raise _Stopped

    def resume(self) -> None:
        """From the main loop: let the lane run until its next step or its end."""
        self._go.release()
        while not self._back.acquire(timeout=_SLICE):
            pass

    def stop(self) -> None:
        """Call the lane off and wait for its thread to end."""
        if not self.done:
            self._stop = True
            self._go.release()
        self._thread.join()


def fly_together(
    ctx: FirmwareContext, runs: Mapping[str, Callable[[LaneContext], R]]
) -> dict[str, R]:
    """Run every procedure of ``runs`` (by name, in order) at once on ``ctx``'s clock; their
    results by name. The first failure (in the fleet's order) ends them all and is raised."""
    if len(runs) == 1:  # one vehicle: its procedure steps the clock itself, no lane needed
        ((name, run),) = runs.items()
        return {name: run(LaneContext(ctx, name, ctx.step))}
    lanes = [_Lane(name, run, ctx) for name, run in runs.items()]
    try:
        while True:
            for lane in lanes:
                if not lane.done:
                    lane.resume()
            for lane in lanes:
                if lane.error is not None:
                    raise lane.error
            if all(lane.done for lane in lanes):
                break
            ctx.step()
    finally:
        for lane in lanes:
            lane.stop()
    return {lane.name: lane.result for lane in lanes}  # type: ignore[misc]
