"""Components run in the simulation's own process: no sockets, no threads.

Each call into them is bounded as a call to a process is: a firmware call by its ``timeout``,
a participant's step by the simulation's step timeout, its construction and setup by its
``start_timeout``; code that overruns is interrupted (``multicosim.local.deadlines``) and
the run fails with NodeTimeoutError (or NodeStartError) naming the component, the simulated
time and the line it was running.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Generic, TypeVar

from ..core.clock import Delivery, Member, StepResult
from ..core.errors import (
    ConfigurationError,
    MessageTypeError,
    MulticosimError,
    NodeError,
    NodeStartError,
    NodeTimeoutError,
    RemoteError,
    SimulationStopped,
    TransportError,
)
from ..core.messages import MsgT, ReplyT, decode, encode, type_name
from ..runtime.context import FirmwareContext, Participant, StepContext, derive_seed
from ..runtime.serve import Firmware
from ..runtime.transport import LocalDriver, LocalParticipantLink
from .deadlines import Expired, run_within
from .environment import LocalEnvironment
from .waits import DEFAULT_SEND_TIMEOUT, DEFAULT_START_TIMEOUT, check_timeout

__all__ = [
    "InProcessComponent",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "InProcessNode",
]

# A handler that keeps stepping is stopped by its driver at the deadline, with the clock in
# a clean state; the watch interrupts it only if it has not stepped for this long after it.
_FIRMWARE_GRACE = 0.5


def _call(
    handler: Callable[[MsgT, FirmwareContext], ReplyT], msg: MsgT, ctx: FirmwareContext
) -> ReplyT:
    try:
        return handler(msg, ctx)
    finally:
        ctx.end_call()


def _interrupted(expired: Expired, what: str = "interrupted") -> str:
    # " (interrupted in step at world.py:12: ...)": the line it was running, where known.
    return f" ({what} in {expired.where})" if expired.where else ""


class InProcessFirmwareNode(Generic[MsgT, ReplyT]):
    """A firmware called directly in the caller's thread (the fastest, low-fidelity path).

    A call gives up after ``timeout`` seconds of wall time, like a call to a firmware process:
    a handler that loops forever raises NodeTimeoutError instead of hanging.
    """

    def __init__(
        self,
        fw: Firmware[MsgT, ReplyT],
        name: str,
        seed: int,
        environment: LocalEnvironment,
        member: Member,
        timeout: float = DEFAULT_SEND_TIMEOUT,
    ) -> None:
        self.firmware = fw
        self.name = name
        self.timeout = timeout
        self._seed = seed
        self._environment = environment
        self._member = member
        self._stopped = False

    def send(self, msg: MsgT, *, timeout: float | None = None) -> ReplyT:
        """Validate ``msg`` as the wire would, run the handler, return its reply."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        fw = self.firmware
        if not isinstance(msg, fw.msgtype):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(fw.msgtype)} (the message type of {self.name!r})"
            )
        if timeout is not None:
            check_timeout("timeout", timeout)
        try:
            checked = decode(encode(msg), fw.msgtype, what=f"message to {self.name!r}")
        except TransportError as exc:
            raise MessageTypeError("msg", msg, str(exc)) from exc
        scheduler = self._environment.scheduler
        limit = self.timeout if timeout is None else timeout
        driver = LocalDriver(scheduler, self._member)
        ctx = FirmwareContext(self.name, self._seed, fw.period_ns, driver)
        ctx.time_ns = scheduler.now_ns
        with scheduler.lock():
            try:
                # The driver stops a handler whose steps come too far apart itself (each
                # ctx.step() checks it, and moves the deadline on); the watch interrupts one
                # that stopped stepping.
                driver.limit(limit)
                reply = run_within(
                    lambda: driver.deadline + _FIRMWARE_GRACE, _call, fw.handler, checked, ctx
                )
            except (NodeError, SimulationStopped):
                # The harness's own failures (a participant crashed or timed out while this
                # firmware waited on the clock, or this call ran out of time while stepping)
                # surface as they would with a remote firmware.
                raise
            except Exception as exc:
                import traceback

                raise RemoteError(
                    self.name, type(exc).__name__, str(exc), traceback.format_exc()
                ) from exc
        if isinstance(reply, Expired):
            raise NodeTimeoutError(
                self.name,
                f"did not answer within {limit:g} s of its last step (its handler was "
                f"interrupted at "
                f"t={scheduler.now_ns / 1e9:g} s of simulated time)"
                f"{_interrupted(reply, 'it was')}",
            )
        return reply

    def stop(self) -> None:
        """Nothing runs between calls; marks the node stopped."""
        self._stopped = True


@dataclasses.dataclass(frozen=True)
class InProcessFirmwareComponent(Generic[MsgT, ReplyT]):
    """A firmware run in the simulation's own process (no sockets, no threads).

    ``timeout`` bounds each call in wall-clock seconds, as for a firmware process.
    """

    firmware: Firmware[MsgT, ReplyT]
    name: str | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT

    def __post_init__(self) -> None:
        if not isinstance(self.firmware, Firmware):
            raise ConfigurationError("firmware", self.firmware, "a function wrapped by @firmware")
        check_timeout("timeout", self.timeout)
        if self.name is None:
            object.__setattr__(self, "name", self.firmware.name)

    def start(self, environment: LocalEnvironment) -> InProcessFirmwareNode[MsgT, ReplyT]:
        """Register the firmware with the clock; it runs when a message is sent."""
        assert self.name is not None
        member = Member(self.name, environment.next_order(), None, drives=True, next_ns=None)
        environment.scheduler.add(member)
        seed = derive_seed(environment.seed, self.name)
        return InProcessFirmwareNode(
            self.firmware, self.name, seed, environment, member, self.timeout
        )


ParticipantT = TypeVar("ParticipantT", bound=Participant)


class InProcessNode(Generic[ParticipantT]):
    """An in-process participant; ``participant`` is the live object (for inspection)."""

    def __init__(self, participant: ParticipantT, name: str) -> None:
        self.participant = participant
        self.name = name

    def stop(self) -> None:
        """Close the participant if it has a ``close`` method."""
        close = getattr(self.participant, "close", None)
        participant, self.participant = self.participant, None  # type: ignore[assignment]
        if close is not None and participant is not None:
            close()


_monotonic = time.monotonic
_unbounded_step = LocalParticipantLink.step


class _BoundedLink(LocalParticipantLink):
    """Steps an in-process participant within the simulation's step timeout.

    A step that overruns it is interrupted and fails the run with the same NodeTimeoutError
    as a process participant's (name, simulated time, and here the line it was running); an
    exception from a step is annotated with the component and the time.
    """

    def __init__(self, participant: Participant, ctx: StepContext, timeout: float) -> None:
        super().__init__(participant, ctx)
        self.timeout = timeout

    def step(self, member: Member, time_ns: int, inbox: list[Delivery]) -> StepResult:
        try:
            # Every in-process step passes here: the plain function, no bound method.
            result = run_within(
                _monotonic() + self.timeout, _unbounded_step, self, member, time_ns, inbox
            )
        except Exception as exc:
            exc.add_note(f"in the step of component {self.ctx.name!r} at t={time_ns / 1e9:g} s")
            raise
        if isinstance(result, Expired):
            raise NodeTimeoutError(
                self.ctx.name,
                f"did not finish its step at t={time_ns / 1e9:g} s within {self.timeout:g} s"
                f"{_interrupted(result)}",
            )
        return result


@dataclasses.dataclass(frozen=True)
class InProcessComponent(Generic[ParticipantT]):
    """A participant (world, injector) stepped in the simulation's own process.

    Each step is bounded by the simulation's ``step_timeout``, as a process participant's
    is; building and setting it up by ``start_timeout`` (wall-clock seconds).
    """

    factory: Callable[[], ParticipantT]
    name: str
    start_timeout: float = DEFAULT_START_TIMEOUT

    def __post_init__(self) -> None:
        check_timeout("start_timeout", self.start_timeout)

    def start(self, environment: LocalEnvironment) -> InProcessNode[ParticipantT]:
        """Build the participant, set it up, and schedule it from the current instant."""
        ctx = StepContext(self.name, derive_seed(environment.seed, self.name))
        participant = run_within(time.monotonic() + self.start_timeout, self._build, ctx)
        if isinstance(participant, Expired):
            raise NodeStartError(
                self.name,
                f"did not become ready within {self.start_timeout:g} s (it was still being "
                f"built or set up){_interrupted(participant)}",
            )
        link = _BoundedLink(participant, ctx, environment.step_timeout)
        member = Member(
            self.name,
            environment.next_order(),
            link,
            drives=False,
            next_ns=environment.scheduler.now_ns,
        )
        environment.scheduler.add(member)
        environment.scheduler.subscribe(member, ctx.take_new_topics())
        return InProcessNode(participant, self.name)

    def _build(self, ctx: StepContext) -> ParticipantT:
        participant = self.factory()
        participant.setup(ctx)
        return participant
