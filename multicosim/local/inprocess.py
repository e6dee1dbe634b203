"""Components run in the simulation's own process: no sockets, no threads."""

from __future__ import annotations

import ctypes
import dataclasses
import itertools
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

from ..core.clock import Member
from ..core.errors import (
    ConfigurationError,
    MessageTypeError,
    MulticosimError,
    NodeError,
    NodeTimeoutError,
    RemoteError,
    SimulationStopped,
    TransportError,
)
from ..core.messages import MsgT, ReplyT, decode, encode, type_name
from ..runtime.context import FirmwareContext, Participant, StepContext, derive_seed
from ..runtime.serve import Firmware
from ..runtime.transport import LocalDriver, LocalParticipantLink
from .environment import LocalEnvironment
from .waits import DEFAULT_SEND_TIMEOUT, check_timeout

__all__ = [
    "InProcessComponent",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "InProcessNode",
]


class _Expired(BaseException):
    """Raised asynchronously in a thread whose in-process firmware call ran out of time.

    A BaseException, so that a handler's ``except Exception`` does not swallow it.
    """


def _interrupt(thread_id: int, exc: type[BaseException] | None) -> None:
    # Raise ``exc`` in that thread at its next Python instruction (None: cancel a pending one).
    ctypes.pythonapi.PyThreadState_SetAsyncExc(
        ctypes.c_ulong(thread_id), None if exc is None else ctypes.py_object(exc)
    )


class _Deadlines:
    """Interrupts in-process firmware calls that outlive their timeout.

    A handler that keeps stepping the clock is stopped cleanly by its driver (each
    ``ctx.step()`` checks the deadline); one that loops without stepping can only be
    interrupted from outside: one daemon thread per process checks the armed calls every
    ``POLL`` seconds and raises :class:`_Expired` in the thread of a call ``GRACE`` seconds
    past its deadline. Arming and disarming cost two dictionary updates. A handler blocked
    inside a C call (``time.sleep``) is interrupted when it returns to Python.
    """

    POLL = 0.1
    GRACE = 0.5

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._armed: dict[int, tuple[int, float]] = {}  # call -> (thread, deadline)
        self._fired: dict[int, int] = {}  # call -> thread
        self._count = itertools.count()
        self._thread: threading.Thread | None = None

    def arm(self, deadline: float) -> int:
        """Watch a call made now by this thread; return its key for :meth:`disarm`."""
        key = next(self._count)
        # A plain dict update (atomic under the GIL): arming costs no lock.
        self._armed[key] = (threading.get_ident(), deadline)
        if self._thread is None:
            with self._lock:
                if self._thread is None:
                    self._thread = threading.Thread(
                        target=self._watch, name="multicosim-deadlines", daemon=True
                    )
                    self._thread.start()
        return key

    def disarm(self, key: int) -> bool:
        """Stop watching call ``key``; True if it was interrupted (or is about to be)."""
        if self._armed.pop(key, None) is not None:
            return False  # the usual case: the watch had not fired, and now it cannot
        me = threading.get_ident()
        with self._lock:  # the watch fired: it has raised, under this lock, in our thread
            if self._fired.pop(key, None) is None:
                return True  # disarmed before: this is the second call for the same key
            if me not in self._fired.values():
                # Not raised yet (the call returned just in time): it must not be raised
                # later, in whatever this thread runs next.
                _interrupt(me, None)
            return True

    def _watch(self) -> None:
        while True:
            time.sleep(self.POLL)
            now = time.monotonic()
            with self._lock:
                for key, (thread, deadline) in list(self._armed.items()):
                    if now > deadline + self.GRACE and self._armed.pop(key, None) is not None:
                        self._fired[key] = thread
                        _interrupt(thread, _Expired)


_deadlines = _Deadlines()


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
            key = _deadlines.arm(driver.limit(limit))
            try:
                try:
                    try:
                        reply = fw.handler(checked, ctx)
                    finally:
                        ctx._finish()
                finally:
                    expired = _deadlines.disarm(key)
            except _Expired:
                if not _deadlines.disarm(key):
                    raise  # an enclosing call's deadline (a handler calling another node)
                expired = True
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
        if expired:
            raise NodeTimeoutError(
                self.name,
                f"did not answer within {limit:g} s (its handler was interrupted at "
                f"t={scheduler.now_ns / 1e9:g} s of simulated time)",
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


@dataclasses.dataclass(frozen=True)
class InProcessComponent(Generic[ParticipantT]):
    """A participant (world, injector) stepped in the simulation's own process."""

    factory: Callable[[], ParticipantT]
    name: str

    def start(self, environment: LocalEnvironment) -> InProcessNode[ParticipantT]:
        """Build the participant, set it up, and schedule it from the current instant."""
        participant = self.factory()
        ctx = StepContext(self.name, derive_seed(environment.seed, self.name))
        participant.setup(ctx)
        link = LocalParticipantLink(participant, ctx)
        member = Member(
            self.name,
            environment.next_order(),
            link,
            drives=False,
            next_ns=environment.scheduler.now_ns,
        )
        environment.scheduler.add(member)
        environment.scheduler.subscribe(member, ctx._take_topics())
        return InProcessNode(participant, self.name)
