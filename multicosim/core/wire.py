"""Frames exchanged over ZeroMQ: the lockstep protocol and the firmware call protocol.

Both are tagged msgspec Structs encoded as MessagePack. Payloads of user messages stay
opaque bytes here; they are decoded against the receiver's declared type.

Who may send them: a simulation gives each component a secret token (``MCS_TOKEN``, 128
random bits). A component's socket to the coordinator uses it as its ZeroMQ routing
identity, and a firmware answers only calls whose identity is its token (the host's socket
uses it too). A frame from any other identity is dropped with a warning naming the peer
(``Drops``), so a process that does not know the token can neither join a run, nor
inject messages, nor disturb it. Connections that do not speak ZeroMQ at all are refused by
ZeroMQ before any frame is read; ``HandshakeFailures`` logs them.
"""

from __future__ import annotations

import contextlib
import logging
import threading
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
    ``describe_peer``); a well-formed message has exactly one frame after it.
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
    except zmq.ZMQError:  # not over TCP, or a peer of ZeroMQ's first protocol version
        address = "at an unknown address"
    identity = head.bytes
    shown = repr(identity[:40]) + ("..." if len(identity) > 40 else "")
    return f"peer {address} (identity {shown})"


class Drops:
    """Warnings for dropped frames, bounded: a flood costs a few log lines, not one a frame.

    The first ``per_peer`` frames of each of the first ``peers`` peers are logged one by one;
    after that, a line at every tenfold of the total (100, 1000, ...).
    """

    def __init__(
        self, where: str, logger: logging.Logger, *, per_peer: int = 3, peers: int = 50
    ) -> None:
        self.where = where
        self.count = 0
        self._logger = logger
        self._per_peer = per_peer
        self._max_peers = peers
        self._peers: dict[str, int] = {}
        self._next_summary = 100

    def drop(self, peer: str, reason: str) -> None:
        """Record (and perhaps log) that a frame from ``peer`` was dropped for ``reason``."""
        self.count += 1
        seen = self._peers.get(peer)
        if seen is None and len(self._peers) < self._max_peers:
            seen = 0
        if seen is not None and seen < self._per_peer:
            self._peers[peer] = seen + 1
            self._logger.warning("%s: dropped a frame from %s: %s", self.where, peer, reason)
            if seen + 1 == self._per_peer:
                self._logger.warning(
                    "%s: further frames from %s are dropped and counted, not logged",
                    self.where,
                    peer,
                )
        elif self.count >= self._next_summary:
            self._next_summary *= 10
            self._logger.warning(
                "%s: %d frames dropped so far (the last from %s: %s)",
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

    ZeroMQ drops such a connection (an HTTP request, a port scanner, half a greeting) before
    a frame reaches the program; its monitor only tells which of our endpoints it hit. A
    thread waits on the monitor (in ZeroMQ, without the GIL), so watching costs nothing on
    the lockstep path and each refusal is logged at once. Some garbage ZeroMQ closes without
    any event (a first byte of 0): that is dropped too, but cannot be reported.
    """

    def __init__(self, socket: zmq.Socket[Any], where: str, logger: logging.Logger) -> None:
        import zmq

        self.where = where
        self.count = 0
        self._logger = logger
        self._socket = socket
        self._reasons = {getattr(zmq, k): v for k, v in _HANDSHAKE_FAILURES.items()}
        events = zmq.EVENT_MONITOR_STOPPED
        for event in self._reasons:
            events |= event
        monitor = socket.get_monitor_socket(events)
        self._thread: threading.Thread | None = threading.Thread(
            target=self._watch, args=(monitor,), name="multicosim-refusals", daemon=True
        )
        self._thread.start()

    def _watch(self, monitor: zmq.Socket[Any]) -> None:
        import zmq
        from zmq.utils.monitor import recv_monitor_message

        try:
            while True:
                event = recv_monitor_message(monitor)
                if event["event"] == zmq.EVENT_MONITOR_STOPPED:
                    return
                self.count += 1
                if self.count <= 20:
                    raw = event.get("endpoint", b"")
                    endpoint = raw.decode(errors="replace") if isinstance(raw, bytes) else raw
                    reason = self._reasons.get(event["event"], f"event {event['event']}")
                    self._logger.warning(
                        "%s: refused a connection to %s: %s", self.where, endpoint, reason
                    )
        except zmq.ZMQError:  # the context was terminated under us
            return
        finally:
            monitor.close(0)

    def close(self) -> None:
        """Stop watching (before the socket is closed)."""
        import zmq

        thread, self._thread = self._thread, None
        if thread is None:
            return
        with contextlib.suppress(zmq.ZMQError):  # the socket is already closed
            self._socket.disable_monitor()
        thread.join(2.0)
