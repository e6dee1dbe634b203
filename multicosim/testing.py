"""Small components for testing simulators and backends, in-process, as processes or in containers.

They are shipped in the package (not only in the test suite) so that every execution
environment, a container image included, can run them::

    python -m multicosim participant multicosim.testing:Cart
    python -m multicosim serve multicosim.testing:drive --port {port}

:func:`check_component` checks a component of one's own the way multicosim runs it
(in-process and as a process: determinism for a seed, idempotent stop, nothing left
behind), as Gymnasium's ``check_env`` checks an environment.
"""

from __future__ import annotations

import os
import time

from .core.messages import Message
from .local.check import Check, ComponentReport, check_component
from .runtime.context import FirmwareContext, StepContext, Subscription
from .runtime.serve import firmware

__all__ = [
    "Cart",
    "CartState",
    "Check",
    "ComponentReport",
    "Drive",
    "DriveReport",
    "Echo",
    "Misbehave",
    "Speed",
    "Stuck",
    "check_component",
    "drive",
    "echo",
    "misbehave",
]


class Speed(Message):
    """Commanded speed of the cart (m/s)."""

    speed: float


class CartState(Message):
    """Position of the cart (m), with the noise-free truth for checks."""

    x: float
    noise: float = 0.0


class Cart:
    """A 1-D cart: integrates the commanded speed every ``period``; publishes ``state``.

    ``noise`` adds seeded Gaussian noise to the published position (exercises ``ctx.rng``).
    """

    def __init__(self, period: float = 0.01, noise: float = 0.0) -> None:
        self.period = period
        self.noise = noise
        self.x = 0.0
        self.speed = 0.0
        self.command: Subscription[Speed] | None = None

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to ``cmd``."""
        self.command = ctx.subscribe("cmd", Speed)

    def step(self, ctx: StepContext) -> None:
        """Apply every command received, integrate, publish."""
        assert self.command is not None
        for msg in self.command.messages:
            self.speed = msg.speed
        self.x += self.speed * self.period
        noise = float(ctx.rng.normal(0.0, self.noise)) if self.noise else 0.0
        ctx.publish("state", CartState(x=self.x + noise, noise=noise))


class Stuck:
    """A participant that steps normally until ``at`` s, then computes forever inside its step.

    It prints ``stuck at t=... (pid N)`` when it starts the endless step (a busy Python
    loop: the process is running, not waiting), for tests of a host killed mid-step.
    """

    def __init__(self, at: float = 0.05, period: float = 0.01) -> None:
        self.at = at
        self.period = period

    def setup(self, ctx: StepContext) -> None:
        """Nothing to subscribe to."""

    def step(self, ctx: StepContext) -> None:
        """Return at once before ``at``; never return from then on."""
        if ctx.time >= self.at:
            print(f"stuck at t={ctx.time:g} (pid {os.getpid()})", flush=True)
            while True:
                pass


class Drive(Message):
    """Drive the cart at ``speed`` for ``steps`` firmware periods."""

    speed: float
    steps: int


class DriveReport(Message):
    """What the driver saw: simulated times and positions at each step."""

    times: list[float]
    positions: list[float]


@firmware(msgtype=Drive, period=0.05)
def drive(msg: Drive, ctx: FirmwareContext) -> DriveReport:
    """Command ``msg.speed`` and record the cart's reported position every step."""
    state = ctx.subscribe("state", CartState)
    times: list[float] = []
    positions: list[float] = []
    for _ in range(msg.steps):
        ctx.step()
        latest = state.latest
        times.append(ctx.time)
        positions.append(latest.x if latest is not None else float("nan"))
        ctx.publish("cmd", Speed(speed=msg.speed))
    return DriveReport(times=times, positions=positions)


class Echo(Message):
    """A message echoed back by :func:`echo`."""

    text: str
    payload: bytes = b""


@firmware(msgtype=Echo)
def echo(msg: Echo, ctx: FirmwareContext) -> Echo:
    """Reply with the message itself (a pure request/reply firmware)."""
    return msg


class Misbehave(Message):
    """Ask :func:`misbehave` to fail in a given way.

    ``how``: ``raise``; ``exit`` with ``code``; ``hang`` (sleep) or ``spin`` (a busy Python
    loop) for ``seconds``; ``step`` (keep stepping the clock, forever); anything else answers.
    """

    how: str
    code: int = 3
    seconds: float = 3600.0


@firmware(msgtype=Misbehave)
def misbehave(msg: Misbehave, ctx: FirmwareContext) -> str:
    """Fail on purpose, to test how failures are reported."""
    if msg.how == "raise":
        raise RuntimeError("asked to raise")
    if msg.how == "exit":
        print("misbehave: exiting on request", flush=True)
        os._exit(msg.code)
    if msg.how == "hang":
        time.sleep(msg.seconds)
    if msg.how == "spin":
        end = time.monotonic() + msg.seconds
        while time.monotonic() < end:
            pass
    if msg.how == "step":
        while True:
            ctx.step()
    return msg.how
