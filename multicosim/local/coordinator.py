"""The host end of the lockstep protocol: the coordinator socket that steps remote members."""

from __future__ import annotations

import hashlib
import logging
import secrets
import time
from typing import Any

import msgspec
import zmq

from ..core import wire
from ..core.clock import Delivery, Member, Scheduler, StepResult
from ..core.errors import NodeStartError, NodeTimeoutError, TransportError
from .waits import DEFAULT_STEP_TIMEOUT, SLICE_MS, Watch, crashed, ending, stalled

__all__ = ["Coordinator"]

log = logging.getLogger(__name__)


class Coordinator:
    """The host end of the lockstep protocol: a ROUTER socket participants connect to.

    Only the run's own components take part: each is admitted with a secret token (see
    ``multicosim.core.wire``) that it uses as its routing identity; frames from any other peer
    are dropped with a warning and change nothing.
    """

    def __init__(
        self,
        scheduler: Scheduler,
        zctx: zmq.Context[Any],
        host: str,
        *,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        self.scheduler = scheduler
        self.socket = zctx.socket(zmq.ROUTER)
        wire.listen_options(self.socket)
        self.socket.setsockopt(zmq.ROUTER_MANDATORY, 1)
        port = self.socket.bind_to_random_port(f"tcp://{host}")
        self.address = f"tcp://{host}:{port}"
        self.step_timeout = step_timeout
        self._secret = secrets.token_bytes(32)
        self._names: dict[bytes, str] = {}  # routing identity -> admitted component
        self._expected: dict[str, tuple[int, Watch | None]] = {}
        self._early: dict[str, wire.Hello] = {}  # hellos that came before expect()
        # Socket.poll builds a Poller per call; the lockstep exchange waits once per step.
        self._solo = zmq.Poller()
        self._solo.register(self.socket, zmq.POLLIN)
        self._pollers: dict[zmq.Socket[Any] | None, zmq.Poller] = {None: self._solo}
        self._hellos: dict[str, wire.Hello] = {}
        self._watches: dict[str, Watch] = {}
        self.drops = wire.Drops(f"coordinator {self.address}", log)
        self.refused = wire.HandshakeFailures(self.socket, f"coordinator {self.address}", log)

    def token(self, name: str) -> str:
        """Admit component ``name`` to this run; return its secret token (``MCS_TOKEN``)."""
        token = hashlib.blake2b(name.encode(), key=self._secret, digest_size=16).hexdigest()
        self._names[token.encode()] = name
        return token

    def expect(self, name: str, order: int, watch: Watch | None) -> None:
        """Announce participant ``name`` (its place in the step order, how to watch it)."""
        self._expected[name] = (order, watch)
        if watch is not None:
            self._watches[name] = watch
        early = self._early.pop(name, None)
        if early is not None:
            self._join(name, early)

    def wait_ready(self, name: str, timeout: float) -> wire.Hello:
        """Wait for ``name``'s hello; raise NodeStartError if it exits or times out first."""
        deadline = time.monotonic() + timeout
        watch = self._expected[name][1]
        while name not in self._hellos:
            self.pump(SLICE_MS, None)
            if name in self._hellos:
                break
            if watch is not None and (code := watch.poll()) is not None:
                raise NodeStartError(
                    name,
                    f"{ending(watch)} before it was ready",
                    exit_code=code,
                    log_tail=watch.log_tail(),
                )
            if time.monotonic() > deadline:
                raise NodeStartError(
                    name,
                    f"did not become ready within {timeout:g} s (no handshake)",
                    log_tail=watch.log_tail() if watch else "",
                )
        return self._hellos[name]

    def pump(self, timeout_ms: int, extra: zmq.Socket[Any] | None = None) -> bool | None:
        """Handle incoming frames for up to ``timeout_ms``.

        Returns True if ``extra`` became readable, False if only coordinator frames came,
        None if nothing came at all (the moment for slower liveness checks).
        """
        poller = self._pollers.get(extra)
        if poller is None:
            # One poller per waiting socket: building one per wait costs a tenth of a
            # round trip.
            poller = self._pollers[extra] = zmq.Poller()
            poller.register(self.socket, zmq.POLLIN)
            if extra is not None:
                poller.register(extra, zmq.POLLIN)
        events = poller.poll(timeout_ms)
        if not events:
            return None
        ready = False
        for sock, _ in events:
            if sock is self.socket:
                self.drain()
            else:
                ready = True
        return ready

    def drain(self) -> None:
        """Handle every frame already queued on the coordinator socket."""
        while self.socket.getsockopt(zmq.EVENTS) & zmq.POLLIN:
            self._handle(*self._receive())

    def _receive(self) -> tuple[str | None, bytes]:
        """The next message: the admitted sender's name and its frame (name None: dropped)."""
        head, parts = wire.receive(self.socket)
        name = self._names.get(head.bytes)
        if name is None:
            self.drops.drop(wire.describe_peer(head), "not a component of this run")
            return None, b""
        if len(parts) != 1:
            raise TransportError(
                f"component {name!r} sent a message of {len(parts)} frames (the protocol has 1)"
            )
        return name, parts[0]

    def _handle(self, name: str | None, raw: bytes) -> wire.Yield | None:
        if name is None:
            return None
        try:
            frame: wire.Hello | wire.Activate | wire.Yield = wire.to_coordinator.decode(raw)
        except msgspec.DecodeError as exc:
            raise TransportError(f"component {name!r} sent a malformed frame: {exc}") from None
        if isinstance(frame, wire.Hello):
            if frame.name != name:
                raise TransportError(f"component {name!r} said hello as {frame.name!r}")
            if name in self._hellos:
                log.warning("ignoring a second hello from %r", name)
            elif name not in self._expected:
                self._early[name] = frame
            else:
                self._join(name, frame)
            return None
        if name not in self._hellos:
            raise TransportError(f"component {name!r} sent {type(frame).__name__} before hello")
        if isinstance(frame, wire.Activate):
            self.scheduler.activate(self.scheduler.member(name), frame.subscribe)
            return None
        return frame

    def _join(self, name: str, hello: wire.Hello) -> None:
        self._hellos[name] = hello
        member = Member(
            name,
            self._expected[name][0],
            _RemoteLink(self, self.token(name).encode()),
            drives=hello.drives,
            next_ns=None if hello.drives else self.scheduler.now_ns,
        )
        self.scheduler.add(member)
        self.scheduler.subscribe(member, hello.subscribe)

    def exchange(
        self, member: Member, identity: bytes, time_ns: int, inbox: list[Delivery]
    ) -> StepResult:
        """Step remote ``member``: send it its inbox, wait for its yield."""
        name = member.name
        step = wire.Step(time_ns, [(d.topic, d.time_ns, d.data) for d in inbox])
        try:
            self.socket.send_multipart([identity, wire.encoder.encode(step)])
        except zmq.ZMQError as exc:
            # No connection for its identity any more: it has gone, or lost the connection.
            watch = self._watches.get(name)
            if watch is None:
                raise TransportError(f"component {name!r} is unreachable") from exc
            gone = "" if watch.poll() is not None else "its connection is gone"
            raise crashed(watch, f"before its step at t={time_ns / 1e9:g} s", gone) from exc
        deadline = time.monotonic() + self.step_timeout
        watch = self._watches.get(name)
        while True:
            if self._solo.poll(SLICE_MS):
                sender, raw = self._receive()
                frame = self._handle(sender, raw)
                if frame is not None:
                    if sender != name:
                        raise TransportError(f"{sender!r} yielded while {name!r} had the turn")
                    outbox = [Delivery(t, time_ns, raw=d) for t, d in frame.outbox]
                    return StepResult(frame.next_ns, outbox, frame.subscribe)
                continue
            if watch is not None and watch.poll() is not None:
                raise crashed(watch, f"during its step at t={time_ns / 1e9:g} s")
            if time.monotonic() > deadline:
                raise NodeTimeoutError(
                    name,
                    f"did not finish its step at t={time_ns / 1e9:g} s within "
                    f"{self.step_timeout:g} s{stalled(watch)}",
                    log_tail=watch.log_tail() if watch else "",
                )

    def check_alive(self) -> None:
        """Raise NodeCrashedError if any watched participant has exited."""
        for name, watch in self._watches.items():
            if name in self._hellos and watch.poll() is not None:
                raise crashed(watch, "while the simulation ran")

    def forget(self, name: str) -> None:
        """Stop watching ``name`` (it is being stopped on purpose)."""
        self._watches.pop(name, None)

    def close(self) -> None:
        """Close the socket (logging the connections it refused)."""
        self.refused.close()
        self.socket.close(0)


class _RemoteLink:
    __slots__ = ("coordinator", "identity")

    def __init__(self, coordinator: Coordinator, identity: bytes) -> None:
        self.coordinator = coordinator
        self.identity = identity

    def step(self, member: Member, time_ns: int, inbox: list[Delivery]) -> StepResult:
        return self.coordinator.exchange(member, self.identity, time_ns, inbox)
