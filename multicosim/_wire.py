"""Frames exchanged over ZeroMQ: the lockstep protocol and the firmware call protocol.

Both are tagged msgspec Structs encoded as MessagePack. Payloads of user messages stay
opaque bytes here; they are decoded against the receiver's declared type.

Who may send them: a simulation gives each component a secret token (``MCS_TOKEN``, 128
random bits). A component's socket to the coordinator uses it as its ZeroMQ routing
identity, and a firmware answers only calls whose identity is its token (the host's socket
uses it too). A frame from any other identity is dropped with a warning naming the peer
(:class:`Drops`), so a process that does not know the token can neither join a run, nor
inject messages, nor disturb it. Connections that do not speak ZeroMQ at all are refused by
ZeroMQ before any frame is read; :class:`HandshakeFailures` logs them.
"""

from __future__ import annotations

import contextlib
import logging
from typing import TYPE_CHECKING, Any

import msgspec

if TYPE_CHECKING:
    import zmq

# Environment variables through which a simulator hands a component process its place in
# the simulation. Read when the component connects, never at import time.
ENV_COORDINATOR = "MCS_COORDINATOR"
ENV_NODE_NAME = "MCS_NODE_NAME"
ENV_SEED = "MCS_SEED"
ENV_RUN_ID = "MCS_RUN_ID"
ENV_BIND_HOST = "MCS_BIND_HOST"  # default address a firmware binds (images set 0.0.0.0)
ENV_TOKEN = "MCS_TOKEN"  # the component's secret: its routing identity, the caller's too

# Bytes in one frame a listening socket accepts: far above any step or reply (a mission's
# trajectory is a few megabytes), but a peer cannot make a socket buffer gigabytes.
MAX_FRAME_BYTES = 1 << 30


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


# -- receiving from peers that may be hostile -------------------------------------------------


def listen_options(socket: zmq.Socket[Any]) -> None:
    """Options of every socket that accepts connections (the coordinator, a firmware)."""
    import zmq

    socket.setsockopt(zmq.LINGER, 0)
    socket.setsockopt(zmq.MAXMSGSIZE, MAX_FRAME_BYTES)


def receive(socket: zmq.Socket[Any]) -> tuple[zmq.Frame, list[bytes]]:
    """One message from a ROUTER: its routing-identity frame and the frames that follow.

    The identity comes as a ``zmq.Frame`` (it carries the peer's address, see
    :func:`describe_peer`); a well-formed message has exactly one frame after it.
    """
    import zmq

    head = socket.recv(copy=False)
    parts: list[bytes] = []
    while socket.getsockopt(zmq.RCVMORE):
        parts.append(socket.recv())
    return head, parts


def describe_peer(head: zmq.Frame) -> str:
    """The peer a message came from: its address and its (truncated) routing identity."""
    import zmq

    try:
        address = head.get("Peer-Address")
    except zmq.ZMQError:  # not over TCP (inproc, ipc)
        address = "unknown"
    identity = head.bytes
    shown = repr(identity[:24]) + ("..." if len(identity) > 24 else "")
    return f"peer {address} (identity {shown})"


class Drops:
    """Warnings for dropped frames: each of the first ``limit``, then at 10x, 100x, ... that.

    A flood of bad frames therefore costs a few log lines, not one per frame.
    """

    def __init__(self, where: str, logger: logging.Logger, limit: int = 20) -> None:
        self.where = where
        self.count = 0
        self._logger = logger
        self._limit = limit
        self._next_summary = limit * 10

    def drop(self, peer: str, reason: str) -> None:
        """Record (and perhaps log) that a frame from ``peer`` was dropped for ``reason``."""
        self.count += 1
        if self.count <= self._limit:
            self._logger.warning("%s: dropped a frame from %s: %s", self.where, peer, reason)
            if self.count == self._limit:
                self._logger.warning(
                    "%s: further dropped frames are counted, not each logged", self.where
                )
        elif self.count >= self._next_summary:
            self._next_summary *= 10
            self._logger.warning(
                "%s: %d frames dropped so far (last from %s: %s)",
                self.where,
                self.count,
                peer,
                reason,
            )


_HANDSHAKE_FAILURES = {
    "EVENT_HANDSHAKE_FAILED_NO_DETAIL": "the connection failed before its handshake finished",
    "EVENT_HANDSHAKE_FAILED_PROTOCOL": "it does not speak ZeroMQ (protocol error)",
    "EVENT_HANDSHAKE_FAILED_AUTH": "it failed authentication",
}


class HandshakeFailures:
    """Logs connections to ``socket`` that ZeroMQ refused because they failed its handshake.

    ZeroMQ drops such a connection (random bytes, a port scanner, a half-open connection)
    before a frame reaches the program; its monitor only tells which of our endpoints it hit.
    Read with :meth:`drain` where a program is idle anyway, never on the lockstep path.
    """

    def __init__(self, socket: zmq.Socket[Any], where: str, logger: logging.Logger) -> None:
        import zmq

        self.where = where
        self._logger = logger
        self._socket = socket
        self._reasons = {getattr(zmq, k): v for k, v in _HANDSHAKE_FAILURES.items()}
        events = 0
        for event in self._reasons:
            events |= event
        self._monitor: zmq.Socket[Any] | None = socket.get_monitor_socket(events)
        self.count = 0

    def drain(self) -> None:
        """Log every refused connection reported since the last call."""
        import zmq
        from zmq.utils.monitor import recv_monitor_message

        monitor = self._monitor
        while monitor is not None and monitor.poll(0):
            event = recv_monitor_message(monitor, zmq.NOBLOCK)
            self.count += 1
            if self.count <= 20:
                raw = event.get("endpoint", b"")
                endpoint = raw.decode(errors="replace") if isinstance(raw, bytes) else str(raw)
                self._logger.warning(
                    "%s: refused a connection to %s: %s",
                    self.where,
                    endpoint,
                    self._reasons.get(event["event"], f"handshake event {event['event']}"),
                )

    def close(self) -> None:
        """Log what is left, then stop monitoring."""
        if self._monitor is None:
            return
        self.drain()
        import zmq

        with contextlib.suppress(zmq.ZMQError):  # the socket is already closed
            self._socket.disable_monitor()
        self._monitor.close(0)
        self._monitor = None
