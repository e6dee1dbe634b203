"""Components for the check_component tests: one good, the others each broken in one way.

A process imports them by name, so the tests put this directory on PYTHONPATH.
"""

from __future__ import annotations

import random
import subprocess
import sys
import threading
from typing import Any

import multicosim as mcs
from multicosim import testing

# What the broken components leave behind, for the tests to clean up.
RELEASE = threading.Event()
SPAWNED: list[subprocess.Popen[bytes]] = []


class Noisy:
    """Good: a cart whose noise comes from the simulation's seeded generator."""

    period = 0.01

    def setup(self, ctx: mcs.StepContext) -> None:
        self.x = 0.0

    def step(self, ctx: mcs.StepContext) -> None:
        self.x += 0.01
        ctx.publish("state", testing.CartState(x=self.x + float(ctx.rng.normal(0.0, 0.1))))


class Unseeded(Noisy):
    """Broken: its noise comes from Python's global generator, which no seed fixes."""

    def step(self, ctx: mcs.StepContext) -> None:
        self.x += 0.01
        ctx.publish("state", testing.CartState(x=self.x + random.gauss(0.0, 0.1)))


class LeavesAThread(Noisy):
    """Broken: starts a thread that outlives the simulation."""

    def setup(self, ctx: mcs.StepContext) -> None:
        super().setup(ctx)
        threading.Thread(target=RELEASE.wait, name="left-behind", daemon=True).start()


class LeavesAProcess(Noisy):
    """Broken: starts a child process and never stops it."""

    def setup(self, ctx: mcs.StepContext) -> None:
        super().setup(ctx)
        SPAWNED.append(subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"]))


class KnowsWhereItRuns(Noisy):
    """Broken: publishes something of its host process, so a process run differs."""

    def step(self, ctx: mcs.StepContext) -> None:
        ctx.publish("state", testing.CartState(x=float("multicosim" in sys.argv[0])))


class Config(mcs.Message):
    """The configuration of ``Configured``."""

    speed: float


class Configured(Noisy):
    """Good: built from a configuration (JSON on a process's command line)."""

    def __init__(self, config: Config) -> None:
        self.speed = config.speed

    def step(self, ctx: mcs.StepContext) -> None:
        self.x += self.speed * self.period
        ctx.publish("state", testing.CartState(x=self.x))


@mcs.firmware(msgtype=testing.Drive)
def fails(msg: testing.Drive, ctx: mcs.FirmwareContext) -> None:
    """Broken: raises on every message."""
    raise RuntimeError("this firmware always fails")


class _Stubborn:
    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.stopped = False

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def stop(self) -> None:
        if self.stopped:
            raise RuntimeError("already stopped")
        self.stopped = True
        self.inner.stop()


class StopsOnce:
    """Broken: a component of one's own whose node raises when stopped a second time."""

    def start(self, environment: Any) -> Any:
        component = mcs.InProcessComponent(Noisy, name="stops-once")
        return _Stubborn(component.start(environment))
