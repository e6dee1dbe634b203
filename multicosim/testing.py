"""Small components for testing simulators and backends, in-process, as processes or in containers.

They are shipped in the package (not only in the test suite) so that every execution
environment, a container image included, can run them:

```bash
python -m multicosim participant multicosim.testing:Cart
python -m multicosim serve multicosim.testing:drive --port {port}
```

[`Faulty`][multicosim.testing.Faulty] misbehaves on cue (stuck in its step, exiting, raising,
allocating without bound), for tests of how the harness reports faults (``tests/faults``).

[`check_component`][multicosim.testing.check_component] checks a component of one's own the way
multicosim runs it (in-process and as a process: determinism for a seed, idempotent stop, nothing
left behind), as Gymnasium's ``check_env`` checks an environment.
"""

from __future__ import annotations

import os
import sys
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
    "Fault",
    "Faulty",
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

    It listens on the topic ``cmd`` for [`Speed`][multicosim.testing.Speed] messages (the last one
    received in a step sets the speed) and publishes a [`CartState`][multicosim.testing.CartState]
    on ``state`` every step: a controller of your own drives it with ``ctx.publish("cmd",
    Speed(speed=1.0))``. ``noise`` adds seeded Gaussian noise to the published position (exercises
    ``ctx.rng``).
    """

    def __init__(self, period: float = 0.01, noise: float = 0.0) -> None:
        self.period = period
        self.noise = noise
        self.x = 0.0
        self.speed = 0.0
        self.command: Subscription[Speed] | None = None

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to ``cmd`` ([`Speed`][multicosim.testing.Speed] messages)."""
        self.command = ctx.subscribe("cmd", Speed)

    def step(self, ctx: StepContext) -> None:
        """Apply every command received, integrate, publish."""
        assert self.command is not None
        for msg in self.command.messages:
            self.speed = msg.speed
        self.x += self.speed * self.period
        noise = float(ctx.rng.normal(0.0, self.noise)) if self.noise else 0.0
        ctx.publish("state", CartState(x=self.x + noise, noise=noise))


class Fault(Message):
    """What [`Faulty`][multicosim.testing.Faulty] does, from simulated time ``at`` (s) on.

    ``how``: ``stuck`` (its step computes forever: a busy Python loop), ``exit`` (it exits
    with code 0), ``raise`` (its step raises RuntimeError), ``setup`` (its setup raises,
    ``at`` unused), ``hog`` (it allocates, and touches, 32 MiB more every step, without
    bound).
    """

    how: str
    at: float = 0.05
    period: float = 0.01


HOG_CHUNK = 32 << 20  # bytes a hog adds per step


class Faulty:
    """A participant that misbehaves on cue, for tests of how faults are reported.

    Until ``fault.at`` it steps normally (and publishes its step count on ``faulty/steps``).
    It announces the fault first, ``HOW at t=T (pid P) [monotonic M]``: ``M`` is
    ``time.monotonic()``, one clock for every process of a machine (containers included),
    so a test can time how long the harness took to report the fault. A hog prints such a
    stamp after every allocation, and when an allocation fails.
    """

    def __init__(self, fault: Fault) -> None:
        self.fault = fault
        self.period = fault.period
        self.steps = 0
        self._hoard: list[bytes] = []

    def setup(self, ctx: StepContext) -> None:
        """Raise for ``setup``; nothing to subscribe to otherwise."""
        if self.fault.how == "setup":
            self._announce(ctx)
            raise RuntimeError("asked to fail in setup")

    def step(self, ctx: StepContext) -> None:
        """Step normally before ``at``; from then on, misbehave as asked."""
        self.steps += 1
        if ctx.time < self.fault.at or self.fault.how == "setup":
            ctx.publish("faulty/steps", Speed(speed=float(self.steps)))
            return
        how = self.fault.how
        if how == "hog":
            self._hog(ctx)
            return
        self._announce(ctx)
        if how == "stuck":
            while True:
                pass
        if how == "exit":
            sys.exit(0)
        if how == "raise":
            raise RuntimeError(f"asked to raise at t={ctx.time:g}")

    def _announce(self, ctx: StepContext) -> None:
        print(
            f"{self.fault.how} at t={ctx.time:g} (pid {os.getpid()}) "
            f"[monotonic {time.monotonic():.6f}]",
            flush=True,
        )

    def _hog(self, ctx: StepContext) -> None:
        if not self._hoard:
            self._announce(ctx)
        try:
            self._hoard.append(b"\x01" * HOG_CHUNK)  # filled: every page is touched
        except MemoryError:
            print(f"MemoryError [monotonic {time.monotonic():.6f}]", flush=True)
            raise
        size = len(self._hoard) * HOG_CHUNK >> 20
        print(f"holding {size} MiB [monotonic {time.monotonic():.6f}]", flush=True)


class Stuck(Faulty):
    """A participant that steps normally until ``at`` s, then computes forever inside its step.

    It prints ``stuck at t=... (pid N)`` when it starts the endless step (a busy Python
    loop: the process is running, not waiting), for tests of a host killed mid-step.
    """

    def __init__(self, at: float = 0.05, period: float = 0.01) -> None:
        super().__init__(Fault("stuck", at, period))


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
    """A message echoed back by [`echo`][multicosim.testing.echo]."""

    text: str
    payload: bytes = b""


@firmware(msgtype=Echo)
def echo(msg: Echo, ctx: FirmwareContext) -> Echo:
    """Reply with the message itself (a pure request/reply firmware)."""
    return msg


class Misbehave(Message):
    """Ask [`misbehave`][multicosim.testing.misbehave] to fail in a given way.

    ``how``: ``raise``; ``exit`` with ``code``; ``hang`` (sleep) or ``spin`` (a busy Python
    loop) for ``seconds``; ``step`` (step the clock for ``seconds`` of simulated time);
    anything else answers.
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
        end = ctx.time + msg.seconds
        while ctx.time < end:
            ctx.step()
    return msg.how
