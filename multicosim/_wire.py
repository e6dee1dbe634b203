"""Frames exchanged over ZeroMQ: the lockstep protocol and the firmware call protocol.

Both are tagged msgspec Structs encoded as MessagePack. Payloads of user messages stay
opaque bytes here; they are decoded against the receiver's declared type.
"""

from __future__ import annotations

import msgspec

# Environment variables through which a simulator hands a component process its place in
# the simulation. Read when the component connects, never at import time.
ENV_COORDINATOR = "MCS_COORDINATOR"
ENV_NODE_NAME = "MCS_NODE_NAME"
ENV_SEED = "MCS_SEED"
ENV_RUN_ID = "MCS_RUN_ID"
ENV_BIND_HOST = "MCS_BIND_HOST"  # default address a firmware binds (images set 0.0.0.0)


class Hello(msgspec.Struct, tag="hello", frozen=True):
    """Participant -> coordinator: I am ready (sent once, after binding every socket)."""

    name: str
    period_ns: int
    drives: bool
    subscribe: list[str]
    pid: int
    port: int = 0  # the firmware call socket's port (0: none)


class Activate(msgspec.Struct, tag="activate", frozen=True):
    """Driver -> coordinator: schedule me from the current instant (a handler started)."""

    subscribe: list[str]


class Step(msgspec.Struct, tag="step", frozen=True):
    """Coordinator -> participant: it is your turn at ``time_ns``; here is your inbox."""

    time_ns: int
    inbox: list[tuple[str, int, bytes]]


class Yield(msgspec.Struct, tag="yield", frozen=True):
    """Participant -> coordinator: my step is done; wake me at ``next_ns`` (None: idle)."""

    next_ns: int | None
    outbox: list[tuple[str, bytes]]
    subscribe: list[str]


class Stop(msgspec.Struct, tag="stop", frozen=True):
    """Coordinator -> participant: the simulation is stopping."""


ToCoordinator = Hello | Activate | Yield
ToParticipant = Step | Stop


class Call(msgspec.Struct, tag="call", frozen=True):
    """Host -> firmware: handle ``payload`` (a message of type ``msgtype``) at ``time_ns``."""

    id: int
    msgtype: str
    payload: bytes
    time_ns: int = 0  # the simulated time when the call was made


class Ping(msgspec.Struct, tag="ping", frozen=True):
    """Host -> firmware: are you there (readiness when no coordinator is involved)."""

    id: int


class Reply(msgspec.Struct, tag="reply", frozen=True):
    """Firmware -> host: the handler's return value."""

    id: int
    payload: bytes


class Pong(msgspec.Struct, tag="pong", frozen=True):
    """Firmware -> host: answer to Ping."""

    id: int
    name: str
    msgtype: str


class Failure(msgspec.Struct, tag="failure", frozen=True):
    """Firmware -> host: the call failed; ``kind`` is "type", "validation" or "exception"."""

    id: int
    kind: str
    error: str
    message: str
    traceback: str = ""


ToFirmware = Call | Ping
FromFirmware = Reply | Pong | Failure

to_coordinator = msgspec.msgpack.Decoder(ToCoordinator)
to_participant = msgspec.msgpack.Decoder(ToParticipant)
to_firmware = msgspec.msgpack.Decoder(ToFirmware)
from_firmware = msgspec.msgpack.Decoder(FromFirmware)
encoder = msgspec.msgpack.Encoder()
