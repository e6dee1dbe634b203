"""Firmware nodes reached over ZeroMQ, and the components that start them locally.

A firmware in a process (or a container, see ``multicosim.docker``) is a ROUTER socket
that answers calls; the host's
[`ProcessFirmwareNode`][multicosim.local.firmware.ProcessFirmwareNode] is the DEALER that calls it
and runs the simulation's clock while it waits for the answer.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Generic

import msgspec
import zmq

from ..core import wire
from ..core.errors import (
    ConfigurationError,
    MessageTypeError,
    MulticosimError,
    NodeStartError,
    NodeTimeoutError,
    RemoteError,
)
from ..core.messages import MsgT, ReplyT, decode, encode, type_name
from ..runtime.serve import Firmware
from .environment import LocalEnvironment
from .processes import check_memory, check_port, default_name, split_command, start_process
from .waits import (
    DEFAULT_SEND_TIMEOUT,
    DEFAULT_START_TIMEOUT,
    SLICE_MS,
    Watch,
    check_timeout,
    crashed,
    stalled,
)

__all__ = [
    "ProcessFirmwareComponent",
    "ProcessFirmwareNode",
    "ThreadFirmwareComponent",
    "check_types",
]


def check_types(msgtype: object, replytype: object) -> None:
    if msgtype is not None and not isinstance(msgtype, type):
        raise ConfigurationError("msgtype", msgtype, "a message class or None")
    if replytype is not None and not isinstance(replytype, type):
        raise ConfigurationError("replytype", replytype, "a message class or None")


class ProcessFirmwareNode(Generic[MsgT, ReplyT]):
    """A CommunicationNode reached over ZeroMQ: a firmware in a process or a container.

    ``send`` runs the simulation's clock while it waits, so the firmware's handler can step
    through simulated time; it gives up after ``timeout`` seconds of wall time, and raises at
    once if the component exits, naming it with its exit code and last output. ``token`` is
    the component's secret (its firmware answers only the identity it names); None for a
    firmware served outside a simulation.
    """

    def __init__(
        self,
        name: str,
        endpoint: str,
        *,
        msgtype: type[MsgT] | None,
        replytype: type[ReplyT] | None,
        timeout: float,
        watch: Watch | None,
        environment: LocalEnvironment | None,
        on_stop: Callable[[], None],
        zctx: zmq.Context[Any] | None = None,
        token: str | None = None,
    ) -> None:
        self.name = name
        self.endpoint = endpoint
        self.msgtype = msgtype
        self.replytype = replytype
        self.timeout = timeout
        self._watch = watch
        self._environment = environment
        self._on_stop = on_stop
        self._socket = (zctx or zmq.Context.instance()).socket(zmq.DEALER)
        self._socket.setsockopt(zmq.LINGER, 0)
        if token is not None:
            self._socket.setsockopt(zmq.ROUTING_ID, token.encode())
        self._socket.connect(endpoint)
        # Checked after every lockstep step while a call runs: a poll is cheaper than a
        # non-blocking recv that raises (and Socket.poll would build a Poller per call).
        self._readable = zmq.Poller()
        self._readable.register(self._socket, zmq.POLLIN)
        self._next_id = 0
        self._stopped = False

    def send(self, msg: MsgT, *, timeout: float | None = None) -> ReplyT:
        """Send ``msg`` to the firmware and return its (validated) reply."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        if self.msgtype is not None and not isinstance(msg, self.msgtype):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(self.msgtype)} (the message type of {self.name!r})"
            )
        self._next_id += 1
        now = self._environment.scheduler.now_ns if self._environment is not None else 0
        call = wire.Call(self._next_id, type_name(type(msg)), encode(msg), now)
        self._socket.send(wire.encoder.encode(call))
        answer = self._wait(call.id, self.timeout if timeout is None else timeout)
        if isinstance(answer, wire.Failure):
            if answer.kind in ("type", "validation"):
                raise MessageTypeError("msg", msg, answer.message)
            raise RemoteError(self.name, answer.error, answer.message, answer.traceback)
        assert isinstance(answer, wire.Reply)
        if self.replytype is None:
            return msgspec.msgpack.decode(answer.payload)  # type: ignore[no-any-return]
        return decode(answer.payload, self.replytype, what=f"reply of {self.name!r}")

    def _wait(self, call_id: int, timeout: float) -> wire.Reply | wire.Failure | wire.Pong:
        # ``timeout`` is liveness: the wait ends that long after the simulated clock last
        # moved (or after the call, if it never does), however long the firmware steps.
        deadline = time.monotonic() + timeout
        sock = self._socket
        env = self._environment
        clock = env.scheduler.now_ns if env is not None else 0
        answer: list[wire.Reply | wire.Failure | wire.Pong] = []

        readable = self._readable

        def arrived() -> bool:
            while not answer:
                if not readable.poll(0):
                    return False
                frame = wire.from_firmware.decode(sock.recv())
                if frame.id == call_id:
                    answer.append(frame)
                # Else: a late answer to a call that timed out; drop it.
            return True

        def idle() -> None:
            if env is not None:
                ready = env.idle(sock)
            else:
                ready = True if sock.poll(SLICE_MS) else None
            if ready is None or time.monotonic() > deadline:
                self._check(deadline, timeout)

        def between() -> None:
            nonlocal deadline, clock
            now = time.monotonic()
            if env is not None and env.scheduler.now_ns != clock:
                clock, deadline = env.scheduler.now_ns, now + timeout
            elif now > deadline:
                self._check(deadline, timeout)

        if env is None:
            while not arrived():
                idle()
            return answer[0]
        scheduler = env.scheduler
        with scheduler.lock():
            # While the clock is stopped (the usual case for a plain request/reply), wait
            # on the sockets directly; the scheduler runs only once a driver activates.
            while not scheduler.running:
                idle()
                if arrived():
                    return answer[0]
            scheduler.run(arrived, idle=idle, between=between)
        return answer[0]

    def _check(self, deadline: float, timeout: float) -> None:
        watch = self._watch
        if watch is not None and watch.poll() is not None:
            raise crashed(watch, "while handling a message")
        if time.monotonic() > deadline:
            raise NodeTimeoutError(
                self.name,
                f"did not answer within {timeout:g} s{stalled(watch)}",
                log_tail=watch.log_tail() if watch else "",
            )

    def ping(self, timeout: float = 5.0) -> wire.Pong:
        """Ask the firmware who it is (readiness check outside a simulation)."""
        self._next_id += 1
        self._socket.send(wire.encoder.encode(wire.Ping(self._next_id)))
        answer = self._wait(self._next_id, timeout)
        assert isinstance(answer, wire.Pong)
        return answer

    def stop(self) -> None:
        """Stop the component behind this node; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        self._socket.close(0)
        self._on_stop()


@dataclasses.dataclass(frozen=True)
class ProcessFirmwareComponent(Generic[MsgT, ReplyT]):
    """A firmware run as a local process, reached as a CommunicationNode over ZeroMQ.

    ``command`` may contain ``{port}``; with ``port=None`` the program binds any free port
    (no collisions between parallel runs) and reports it in its handshake. ``memory`` caps
    its address space, as ``ProcessComponent``'s does.
    """

    command: str | Sequence[str]
    port: int | None = None
    msgtype: type[MsgT] | None = None
    replytype: type[ReplyT] | None = None
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    cwd: str | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = 5.0
    memory: int | str | None = None

    def __post_init__(self) -> None:
        args = split_command(self.command)
        check_port(self.port)
        check_memory(self.memory)
        check_types(self.msgtype, self.replytype)
        for field in ("timeout", "start_timeout", "stop_timeout"):
            check_timeout(field, getattr(self, field))
        if self.name is None:
            object.__setattr__(self, "name", default_name(args))

    def start(self, environment: LocalEnvironment) -> ProcessFirmwareNode[MsgT, ReplyT]:
        """Start the firmware process and wait for its handshake."""
        assert self.name is not None
        port = str(self.port or 0)
        args = [a.replace("{port}", port) for a in split_command(self.command)]
        node, hello = start_process(
            environment,
            self.name,
            args,
            env=self.env,
            cwd=self.cwd,
            handshake=True,
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
            memory=self.memory,
        )
        assert hello is not None
        if not hello.port:
            node.stop()
            raise NodeStartError(self.name, "joined the simulation without a firmware port")
        return ProcessFirmwareNode(
            self.name,
            f"tcp://127.0.0.1:{hello.port}",
            msgtype=self.msgtype,
            replytype=self.replytype,
            timeout=self.timeout,
            watch=node.handle,
            environment=environment,
            on_stop=node.stop,
            zctx=environment.zctx,
            token=environment.coordinator.token(self.name),
        )


class _ThreadWatch:
    """Watches a firmware served in a thread: it 'exits' when the thread ends."""

    def __init__(self, name: str, thread: threading.Thread, errors: list[str]) -> None:
        self.name = name
        self.thread = thread
        self.errors = errors

    def poll(self) -> int | None:
        return None if self.thread.is_alive() else (1 if self.errors else 0)

    def log_tail(self, lines: int = 40) -> str:
        return "\n".join("\n".join(self.errors).splitlines()[-lines:])


@dataclasses.dataclass(frozen=True)
class ThreadFirmwareComponent(Generic[MsgT, ReplyT]):
    """A firmware served by a thread of the simulation's process, over real sockets.

    It runs exactly as in a process or a container (same server, same protocol), which makes
    it the cheapest way to test a firmware's wire behaviour.
    """

    firmware: Firmware[MsgT, ReplyT]
    replytype: type[ReplyT] | None = None
    name: str | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT
    start_timeout: float = DEFAULT_START_TIMEOUT

    def __post_init__(self) -> None:
        if not isinstance(self.firmware, Firmware):
            raise ConfigurationError("firmware", self.firmware, "a function wrapped by @firmware")
        check_types(None, self.replytype)
        check_timeout("timeout", self.timeout)
        if self.name is None:
            object.__setattr__(self, "name", self.firmware.name)

    def start(self, environment: LocalEnvironment) -> ProcessFirmwareNode[MsgT, ReplyT]:
        """Serve the firmware in a thread and wait for its handshake."""
        from ..runtime.serve import serve

        name = self.name
        assert name is not None
        stop = threading.Event()
        errors: list[str] = []
        coordinator = environment.coordinator
        token = coordinator.token(name)

        def run() -> None:
            try:
                serve(
                    self.firmware,
                    stop=stop,
                    environment=(coordinator.address, name, environment.seed),
                    token=token,
                )
            except BaseException:
                import traceback

                errors.append(traceback.format_exc())

        thread = threading.Thread(target=run, name=f"firmware-{name}", daemon=True)
        watch = _ThreadWatch(name, thread, errors)
        coordinator.expect(name, environment.next_order(), watch)
        thread.start()

        def halt() -> None:
            stop.set()
            thread.join(5.0)

        try:
            hello = coordinator.wait_ready(name, self.start_timeout)
        except BaseException:
            halt()
            raise
        return ProcessFirmwareNode(
            name,
            f"tcp://127.0.0.1:{hello.port}",
            msgtype=self.firmware.msgtype,
            replytype=self.replytype,
            timeout=self.timeout,
            watch=watch,
            environment=environment,
            on_stop=halt,
            zctx=environment.zctx,
            token=token,
        )
