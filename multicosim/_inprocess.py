"""Components run in the simulation's own process: no sockets, no threads."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Generic, TypeVar

from ._clock import Member
from ._environment import LocalEnvironment
from ._errors import (
    ConfigurationError,
    MessageTypeError,
    MulticosimError,
    NodeError,
    RemoteError,
    SimulationStopped,
    TransportError,
)
from ._messages import decode, encode, type_name
from ._runtime import (
    Firmware,
    FirmwareContext,
    LocalDriver,
    LocalParticipantLink,
    Participant,
    StepContext,
    derive_seed,
)

__all__ = [
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "ParticipantComponent",
    "ParticipantNode",
]

MsgT = TypeVar("MsgT")
ReplyT = TypeVar("ReplyT")


class InProcessFirmwareNode(Generic[MsgT, ReplyT]):
    """A firmware called directly in the caller's thread (the fastest, low-fidelity path)."""

    def __init__(
        self,
        fw: Firmware[MsgT, ReplyT],
        name: str,
        seed: int,
        environment: LocalEnvironment,
        member: Member,
    ) -> None:
        self.firmware = fw
        self.name = name
        self._seed = seed
        self._environment = environment
        self._member = member
        self._stopped = False

    def send(self, msg: MsgT) -> ReplyT:
        """Validate ``msg`` as the wire would, run the handler, return its reply."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        fw = self.firmware
        if not isinstance(msg, fw.msgtype):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(fw.msgtype)} (the message type of {self.name!r})"
            )
        try:
            checked = decode(encode(msg), fw.msgtype, what=f"message to {self.name!r}")
        except TransportError as exc:
            raise MessageTypeError("msg", msg, str(exc)) from exc
        scheduler = self._environment.scheduler
        ctx = FirmwareContext(
            self.name, self._seed, fw.period_ns, LocalDriver(scheduler, self._member)
        )
        ctx.time_ns = scheduler.now_ns
        with scheduler.lock():
            try:
                try:
                    return fw.handler(checked, ctx)
                finally:
                    ctx._finish()
            except (NodeError, SimulationStopped):
                # The harness's own failures (a participant crashed or timed out while this
                # firmware waited on the clock) surface as they would with a remote firmware.
                raise
            except Exception as exc:
                import traceback

                raise RemoteError(
                    self.name, type(exc).__name__, str(exc), traceback.format_exc()
                ) from exc

    def stop(self) -> None:
        """Nothing runs between calls; marks the node stopped."""
        self._stopped = True


@dataclasses.dataclass(frozen=True)
class InProcessFirmwareComponent(Generic[MsgT, ReplyT]):
    """A firmware run in the simulation's own process (no sockets, no threads)."""

    firmware: Firmware[MsgT, ReplyT]
    name: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.firmware, Firmware):
            raise ConfigurationError("firmware", self.firmware, "a function wrapped by @firmware")
        if self.name is None:
            object.__setattr__(self, "name", self.firmware.name)

    def start(self, environment: LocalEnvironment) -> InProcessFirmwareNode[MsgT, ReplyT]:
        """Register the firmware with the clock; it runs when a message is sent."""
        assert self.name is not None
        member = Member(self.name, environment.next_order(), None, drives=True, next_ns=None)
        environment.scheduler.add(member)
        seed = derive_seed(environment.seed, self.name)
        return InProcessFirmwareNode(self.firmware, self.name, seed, environment, member)


ParticipantT = TypeVar("ParticipantT", bound=Participant)


class ParticipantNode(Generic[ParticipantT]):
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
class ParticipantComponent(Generic[ParticipantT]):
    """A participant (world, injector) stepped in the simulation's own process."""

    factory: Callable[[], ParticipantT]
    name: str

    def start(self, environment: LocalEnvironment) -> ParticipantNode[ParticipantT]:
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
        return ParticipantNode(participant, self.name)
