"""The component side: step contexts, topics, the firmware decorator and its server.

A component is written once against :class:`StepContext` (publish, subscribe, simulated time,
seeded randomness) and runs unchanged in-process, in a local process or in a container:
only the link to the scheduler differs (a direct call or a ZeroMQ socket).

Two kinds of component exist:

* a **participant** (the physics world, an injector): an object with ``period``, ``setup(ctx)``
  and ``step(ctx)``; the scheduler calls ``step`` every ``period`` of simulated time;
* a **firmware** (a controller): a function decorated with :func:`firmware`, called with each
  message sent to its node; it advances the clock itself with ``ctx.step()`` and its return
  value is the reply.
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
import signal
import threading
import time
import traceback
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Generic, Protocol, TypeVar, runtime_checkable

import msgspec

from . import _wire as wire
from ._clock import NS, Delivery, Member, Scheduler, StepResult, to_ns
from ._errors import (
    ConfigurationError,
    MessageTypeError,
    MulticosimError,
    NodeTimeoutError,
    SimulationStopped,
    TransportError,
    translate,
)
from ._messages import MsgT, ReplyT, decode, encode, type_name

if TYPE_CHECKING:
    import numpy as np
    import zmq

__all__ = [
    "Firmware",
    "FirmwareContext",
    "Participant",
    "StepContext",
    "Subscription",
    "derive_seed",
    "firmware",
    "run_participant",
    "serve",
]

log = logging.getLogger(__name__)

T = TypeVar("T")

# How often a waiting component checks that its parent still exists, so that a component
# whose host was killed exits instead of lingering.
_PARENT_CHECK_MS = 1000


def derive_seed(seed: int, name: str) -> int:
    """A per-component seed derived from the simulation seed and the component's name."""
    digest = hashlib.blake2b(f"{seed}:{name}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") >> 1


class Subscription(Generic[T]):
    """Messages of one topic, decoded as ``type``; refreshed at every step."""

    __slots__ = ("_cache", "_deliveries", "_latest", "_latest_time_ns", "topic", "type")

    def __init__(self, topic: str, tp: type[T]) -> None:
        self.topic = topic
        self.type = tp
        self._deliveries: list[Delivery] = []
        self._cache: list[T] | None = None
        self._latest: T | None = None
        self._latest_time_ns: int | None = None

    @property
    def messages(self) -> list[T]:
        """Every message delivered at this step, oldest first (none lost)."""
        if self._cache is None:
            self._cache = [d.as_type(self.type) for d in self._deliveries]
            if self._cache:
                self._latest = self._cache[-1]
        return self._cache

    @property
    def latest(self) -> T | None:
        """The most recent message received so far, or None before the first."""
        if self._deliveries and self._cache is None:
            self._latest = self._deliveries[-1].as_type(self.type)
        return self._latest

    @property
    def latest_time(self) -> float | None:
        """Simulated time (s) at which the latest message was published."""
        return None if self._latest_time_ns is None else self._latest_time_ns / NS

    def _reset(self) -> None:
        if self._deliveries:
            if self._cache is None:
                self._latest = self._deliveries[-1].as_type(self.type)
            self._deliveries = []
        self._cache = None

    def _deliver(self, delivery: Delivery) -> None:
        self._deliveries.append(delivery)
        self._latest_time_ns = delivery.time_ns


class StepContext:
    """What a component sees of the simulation: simulated time, topics, its seed."""

    def __init__(self, name: str, seed: int) -> None:
        self.name = name
        self.seed = seed
        self.time_ns = 0
        self._outbox: list[Delivery] = []
        self._subs: dict[str, Subscription[Any]] = {}
        self._new_topics: list[str] = []
        self._rng: np.random.Generator | None = None

    @property
    def time(self) -> float:
        """Current simulated time in seconds."""
        return self.time_ns / NS

    @property
    def rng(self) -> np.random.Generator:
        """A NumPy generator seeded from the simulation seed and this component's name."""
        if self._rng is None:
            import numpy as np

            self._rng = np.random.default_rng(self.seed)
        return self._rng

    def publish(self, topic: str, msg: object) -> None:
        """Publish ``msg`` on ``topic``; subscribers receive it in this same instant."""
        self._outbox.append(Delivery(topic, self.time_ns, obj=msg))

    def subscribe(self, topic: str, tp: type[T]) -> Subscription[T]:
        """Receive ``topic`` as messages of type ``tp`` (validated on receipt)."""
        existing = self._subs.get(topic)
        if existing is not None:
            if existing.type is not tp:
                raise MessageTypeError(
                    "tp", tp, f"{type_name(existing.type)}, the type {topic!r} is subscribed as"
                )
            return existing
        sub = Subscription(topic, tp)
        self._subs[topic] = sub
        self._new_topics.append(topic)
        return sub

    def _begin(self, time_ns: int, inbox: list[Delivery]) -> None:
        self.time_ns = time_ns
        for sub in self._subs.values():
            sub._reset()
        subs = self._subs
        for d in inbox:
            target = subs.get(d.topic)
            if target is not None:
                target._deliver(d)

    def _take_topics(self) -> list[str]:
        topics, self._new_topics = self._new_topics, []
        return topics

    def _take(self) -> tuple[list[Delivery], list[str]]:
        outbox, self._outbox = self._outbox, []
        topics, self._new_topics = self._new_topics, []
        return outbox, topics


@runtime_checkable
class Participant(Protocol):
    """A component stepped by the scheduler every ``period`` simulated seconds."""

    period: float

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to topics and prepare state; called once before the first step."""
        ...

    def step(self, ctx: StepContext) -> None:
        """Advance by one period: read subscriptions, publish results."""
        ...


class _Driver(Protocol):
    def activate(self, topics: list[str]) -> tuple[int, list[Delivery]]: ...
    def yield_(
        self, next_ns: int, outbox: list[Delivery], topics: list[str]
    ) -> tuple[int, list[Delivery]]: ...
    def deactivate(self, outbox: list[Delivery], topics: list[str]) -> None: ...


class FirmwareContext(StepContext):
    """The context of a firmware handler: a StepContext that advances the clock itself."""

    def __init__(self, name: str, seed: int, period_ns: int, driver: _Driver | None) -> None:
        super().__init__(name, seed)
        self.period = period_ns / NS
        self._period_ns = period_ns
        self._driver = driver
        self._active = False

    def step(self, duration: float | None = None) -> None:
        """Finish this step and wait until ``duration`` (default: the period) has passed.

        Messages published since the last step are delivered; subscriptions then hold what
        arrived meanwhile. The first call starts the clock for this firmware.
        """
        if self._driver is None:
            raise MulticosimError(
                f"firmware {self.name!r} runs without a simulation clock: start it through a "
                "simulator to use ctx.step()"
            )
        outbox, topics = self._take()
        if not self._active:
            time_ns, inbox = self._driver.activate(topics)
            self._active = True
            # Anything published before the first step goes out at the first instant.
            self._outbox = outbox
        else:
            step_ns = self._period_ns if duration is None else to_ns(duration, field="duration")
            time_ns, inbox = self._driver.yield_(self.time_ns + step_ns, outbox, topics)
        self._begin(time_ns, inbox)

    def _finish(self) -> None:
        if self._active and self._driver is not None:
            outbox, topics = self._take()
            self._active = False
            self._driver.deactivate(outbox, topics)


class Firmware(Generic[MsgT, ReplyT]):
    """A firmware: the handler, the message type it accepts and its step period."""

    def __init__(
        self,
        handler: Callable[[MsgT, FirmwareContext], ReplyT],
        msgtype: type[MsgT],
        period: float,
        name: str,
    ) -> None:
        self.handler = handler
        self.msgtype = msgtype
        self.period = period
        self.period_ns = to_ns(period)
        self.name = name

    def __call__(self, msg: MsgT, ctx: FirmwareContext) -> ReplyT:
        return self.handler(msg, ctx)

    def __repr__(self) -> str:
        return f"Firmware({self.name!r}, msgtype={type_name(self.msgtype)})"

    def main(self, argv: list[str] | None = None) -> None:
        """Command-line entry: ``PROGRAM --port PORT [--host HOST]``; serves until stopped."""
        import argparse

        parser = argparse.ArgumentParser(prog=self.name, description=f"serve {self!r}")
        parser.add_argument(
            "--port", type=port_argument, default=0, help="port to serve on (0: any)"
        )
        parser.add_argument(
            "--host", default=default_bind_host(), help="address to bind (env MCS_BIND_HOST)"
        )
        args = parser.parse_args(argv)
        serve(self, port=args.port, host=args.host)


def firmware(
    *, msgtype: type[MsgT], period: float = 0.01, name: str | None = None
) -> Callable[[Callable[[MsgT, FirmwareContext], ReplyT]], Firmware[MsgT, ReplyT]]:
    """Declare a firmware handler, the paper's component-side program::

    @mcs.firmware(msgtype=Mission, period=0.02)
    def controller(mission: Mission, ctx: mcs.FirmwareContext) -> Trajectory:
        ...
    """
    if not isinstance(msgtype, type):
        raise ConfigurationError("msgtype", msgtype, "a message type (a class)")

    def wrap(handler: Callable[[MsgT, FirmwareContext], ReplyT]) -> Firmware[MsgT, ReplyT]:
        return Firmware(handler, msgtype, period, name or handler.__name__)

    return wrap


def handle_call(
    fw: Firmware[Any, Any], call: wire.Call, ctx: FirmwareContext
) -> wire.Reply | wire.Failure:
    """Decode, validate and handle one call; failures become Failure frames."""
    expected = type_name(fw.msgtype)
    if call.msgtype != expected:
        return wire.Failure(
            call.id, "type", "MessageTypeError", f"{fw.name} expects {expected}, got {call.msgtype}"
        )
    try:
        msg = decode(call.payload, fw.msgtype, what=f"message to {fw.name!r}")
    except TransportError as exc:
        return wire.Failure(call.id, "validation", "TransportError", str(exc))
    try:
        try:
            result = fw.handler(msg, ctx)
        finally:
            ctx._finish()
        return wire.Reply(call.id, encode(result))
    except SimulationStopped:
        raise
    except Exception as exc:
        return wire.Failure(
            call.id, "exception", type(exc).__name__, str(exc), traceback.format_exc()
        )


# -- remote link ----------------------------------------------------------------------------


class Connection:
    """A component's socket to the coordinator (a DEALER whose identity is its token).

    ``own_process``: this process is the component (not a thread of the host), so it must
    end when the host has gone, even in the middle of a step (see :class:`HostWatch`).
    """

    def __init__(
        self,
        address: str,
        name: str,
        zctx: zmq.Context[Any] | None = None,
        *,
        token: str | None = None,
        own_process: bool = False,
    ) -> None:
        import zmq

        self.name = name
        self._zctx = zctx or zmq.Context.instance()
        self.socket = self._zctx.socket(zmq.DEALER)
        self.socket.setsockopt(zmq.LINGER, 0)
        # The coordinator admits only the identities it handed out (a secret token).
        self.socket.setsockopt(zmq.ROUTING_ID, (token or name).encode())
        # Heartbeats notice a coordinator that vanished without closing its connection.
        self.socket.setsockopt(zmq.HEARTBEAT_IVL, 1000)
        self.socket.setsockopt(zmq.HEARTBEAT_TIMEOUT, 5000)
        # In a container the parent never changes (it is the init process), so a lost
        # connection is how a component learns that its host was killed.
        monitor = self.socket.get_monitor_socket(zmq.EVENT_DISCONNECTED)
        self.socket.connect(address)
        self.watch = HostWatch(name, monitor) if own_process else None
        self._monitor = None if own_process else monitor
        if self.watch is not None:
            self.watch.start()
        # Socket.poll builds a Poller per call: keep one (a wait per lockstep step).
        self._poller = zmq.Poller()
        self._poller.register(self.socket, zmq.POLLIN)

    def send(self, frame: wire.Hello | wire.Activate | wire.Yield) -> None:
        """Send one frame to the coordinator."""
        self.socket.send(wire.encoder.encode(frame))

    def recv(self) -> wire.Step | wire.Stop:
        """Wait for the coordinator's next frame; a Stop raises SimulationStopped.

        The wait has no simulated deadline (the clock may be paused while the host is idle),
        but it ends when the process that started this one has gone.
        """
        while not self._poller.poll(_PARENT_CHECK_MS):
            if self.orphaned():
                raise SimulationStopped(f"{self.name}: the simulation host has gone")
        frame: wire.Step | wire.Stop = wire.to_participant.decode(self.socket.recv())
        if isinstance(frame, wire.Stop):
            raise SimulationStopped(f"{self.name}: the simulation was stopped")
        return frame

    def orphaned(self) -> bool:
        """True once the host is gone (the coordinator disconnected, or our parent changed)."""
        if self.watch is not None:
            return self.watch.gone.is_set()
        import zmq
        from zmq.utils.monitor import recv_monitor_message

        while self._monitor is not None and self._monitor.poll(0):
            event = recv_monitor_message(self._monitor, zmq.NOBLOCK)
            if event["event"] == zmq.EVENT_DISCONNECTED:
                return True
        return False

    def close(self) -> None:
        """Close the socket and its monitor."""
        self.socket.disable_monitor()
        if self.watch is not None:
            self.watch.stop()
        if self._monitor is not None:
            self._monitor.close(0)
        self.socket.close(0)


class HostWatch(threading.Thread):
    """Ends this component process once its simulation host has gone, even mid-step.

    A thread, so that it notices while the component computes a long step: the coordinator's
    connection is lost (a host killed with SIGKILL, in a container too) or this process's
    parent changed. An idle component notices by itself and exits cleanly
    (``Connection.orphaned``); one still busy ``EXIT_GRACE`` seconds later exits at once.
    On Linux a local component also gets SIGKILL when its host dies (the parent-death signal
    the simulator sets), which makes this the second line of defence there.
    """

    EXIT_GRACE = 2.0
    EXIT_CODE = 75  # EX_TEMPFAIL: not the component's fault

    def __init__(self, name: str, monitor: zmq.Socket[Any]) -> None:
        super().__init__(name=f"{name}-host-watch", daemon=True)
        self.component = name
        self.gone = threading.Event()
        self._monitor = monitor
        self._ppid = os.getppid()
        self._stopped = threading.Event()

    def run(self) -> None:
        import zmq
        from zmq.utils.monitor import recv_monitor_message

        monitor = self._monitor
        try:
            while not self._stopped.is_set():
                if monitor.poll(250):
                    event = recv_monitor_message(monitor, zmq.NOBLOCK)
                    if event["event"] == zmq.EVENT_DISCONNECTED:
                        break
                if os.getppid() != self._ppid:
                    break
            else:
                return
        finally:
            monitor.close(0)
        self.gone.set()
        log.warning("%s: the simulation host has gone", self.component)
        if self._stopped.wait(self.EXIT_GRACE):
            return
        log.warning("%s: still busy %g s later; exiting now", self.component, self.EXIT_GRACE)
        os._exit(self.EXIT_CODE)

    def stop(self) -> None:
        """Stop watching (the component is closing its connection); returns at once."""
        self._stopped.set()


def _inbox(step: wire.Step) -> list[Delivery]:
    return [Delivery(topic, t, raw=data) for topic, t, data in step.inbox]


def _outbox(outbox: list[Delivery]) -> list[tuple[str, bytes]]:
    return [(d.topic, d.data) for d in outbox]


class RemoteDriver:
    """Drives a firmware's clock through a Connection."""

    def __init__(self, conn: Connection) -> None:
        self.conn = conn

    def activate(self, topics: list[str]) -> tuple[int, list[Delivery]]:
        self.conn.send(wire.Activate(topics))
        step = self.conn.recv()
        assert isinstance(step, wire.Step)
        return step.time_ns, _inbox(step)

    def yield_(
        self, next_ns: int, outbox: list[Delivery], topics: list[str]
    ) -> tuple[int, list[Delivery]]:
        self.conn.send(wire.Yield(next_ns, _outbox(outbox), topics))
        step = self.conn.recv()
        assert isinstance(step, wire.Step)
        return step.time_ns, _inbox(step)

    def deactivate(self, outbox: list[Delivery], topics: list[str]) -> None:
        self.conn.send(wire.Yield(None, _outbox(outbox), topics))


class LocalDriver:
    """Drives an in-process firmware's clock by running the scheduler in the caller's thread.

    After :meth:`limit`, a step past the deadline raises NodeTimeoutError.
    """

    def __init__(self, scheduler: Scheduler, member: Member) -> None:
        self.scheduler = scheduler
        self.member = member
        self.deadline = math.inf
        self.timeout = math.inf

    def limit(self, timeout: float) -> float:
        """Give the handler ``timeout`` wall-clock seconds from now; return the deadline."""
        self.timeout = timeout
        self.deadline = time.monotonic() + timeout
        return self.deadline

    def _my_turn(self) -> tuple[int, list[Delivery]]:
        # Scheduler.run specialised to "until it is my turn": this driver is active, so the
        # clock runs, and the next member is found once per step instead of twice.
        if time.monotonic() > self.deadline:
            raise NodeTimeoutError(
                self.member.name,
                f"did not answer within {self.timeout:g} s (its handler was still stepping "
                f"at t={self.scheduler.now_ns / 1e9:g} s of simulated time)",
            )
        sched, me = self.scheduler, self.member
        next_member, step_member = sched.next_member, sched.step_member
        while (member := next_member()) is not me:
            if sched.closed:
                raise MulticosimError("the simulation was stopped")
            if member is None:  # pragma: no cover - impossible while this driver is scheduled
                raise MulticosimError(f"{me.name}: the clock stopped while it was active")
            step_member(member)
        assert me.next_ns is not None
        sched.now_ns = me.next_ns
        inbox, me.inbox = me.inbox, []
        return me.next_ns, inbox

    def activate(self, topics: list[str]) -> tuple[int, list[Delivery]]:
        self.scheduler.activate(self.member, topics)
        return self._my_turn()

    def yield_(
        self, next_ns: int, outbox: list[Delivery], topics: list[str]
    ) -> tuple[int, list[Delivery]]:
        self.scheduler.finish(self.member, StepResult(next_ns, outbox, topics))
        return self._my_turn()

    def deactivate(self, outbox: list[Delivery], topics: list[str]) -> None:
        self.scheduler.finish(self.member, StepResult(None, outbox, topics))


class LocalParticipantLink:
    """Steps an in-process participant by calling it."""

    def __init__(self, participant: Participant, ctx: StepContext) -> None:
        self.participant = participant
        self.ctx = ctx
        self.period_ns = to_ns(participant.period)

    def step(self, member: Member, time_ns: int, inbox: list[Delivery]) -> StepResult:
        ctx = self.ctx
        ctx._begin(time_ns, inbox)
        self.participant.step(ctx)
        outbox, topics = ctx._take()
        return StepResult(time_ns + self.period_ns, outbox, topics)


# -- component programs ---------------------------------------------------------------------


def default_bind_host() -> str:
    """Where a firmware binds unless told: MCS_BIND_HOST (0.0.0.0 in images), else loopback."""
    return os.environ.get(wire.ENV_BIND_HOST, "127.0.0.1")


def _environment() -> tuple[str | None, str, int]:
    address = os.environ.get(wire.ENV_COORDINATOR)
    name = os.environ.get(wire.ENV_NODE_NAME, "component")
    seed = int(os.environ.get(wire.ENV_SEED, "0"))
    return address, name, seed


def _token(address: str | None) -> str | None:
    token = os.environ.get(wire.ENV_TOKEN) or None
    if address is not None and token is None:
        raise MulticosimError(
            f"{wire.ENV_TOKEN} is not set: components join a simulation only when its "
            "simulator starts them"
        )
    return token


def port_argument(text: str) -> int:
    """The type of a ``--port`` option: 0 (any free port) or 1..65535; nothing wraps around."""
    import argparse

    try:
        return check_port_number(int(text))
    except (ValueError, ConfigurationError):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a port: expected 1..65535, or 0 for any free port"
        ) from None


def check_port_number(port: object) -> int:
    """Return ``port`` if it is a TCP port a firmware can bind: 1..65535, or 0 for any."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ConfigurationError("port", port, "an integer in 1..65535, or 0 for any free port")
    return port


def _install_sigterm() -> None:
    # Python ignores SIGTERM as PID 1 in a container; turn it into a clean exit everywhere.
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(SystemExit(0)))


def run_participant(participant: Participant) -> None:
    """Run ``participant`` as a process, stepped by the coordinator named in the environment."""
    address, name, seed = _environment()
    if address is None:
        raise MulticosimError(
            f"{wire.ENV_COORDINATOR} is not set: participants are started by a simulator"
        )
    token = _token(address)
    _install_sigterm()
    ctx = StepContext(name, derive_seed(seed, name))
    participant.setup(ctx)
    period_ns = to_ns(participant.period)
    conn = Connection(address, name, token=token, own_process=True)
    try:
        outbox, topics = ctx._take()
        conn.send(wire.Hello(name, period_ns, False, topics, os.getpid()))
        pending = _outbox(outbox)
        while True:
            step = conn.recv()
            assert isinstance(step, wire.Step)
            ctx._begin(step.time_ns, _inbox(step))
            participant.step(ctx)
            outbox, topics = ctx._take()
            conn.send(wire.Yield(step.time_ns + period_ns, pending + _outbox(outbox), topics))
            pending = []
    except SimulationStopped as exc:
        log.info("%s", exc)
    finally:
        conn.close()


def serve(
    fw: Firmware[Any, Any],
    *,
    port: int = 0,
    host: str | None = None,
    stop: threading.Event | None = None,
    zctx: zmq.Context[Any] | None = None,
    environment: tuple[str | None, str, int] | None = None,
    token: str | None = None,
) -> None:
    """Serve ``fw`` on ``host:port`` until the simulation stops it (or ``stop`` is set).

    Each call is decoded and validated against ``fw.msgtype``; the handler's return value is
    the reply, an exception becomes a RemoteError on the caller's side. Within a simulation
    the firmware says hello to the coordinator, which is how the host knows it is ready, and
    answers only its host (calls must come from the identity ``token``, ``MCS_TOKEN`` by
    default); other frames are dropped with a warning. ``port`` 0 binds any free port.
    """
    import zmq

    check_port_number(port)
    if environment is None:
        environment = _environment()
        token = token or _token(environment[0])
    address, name, seed = environment
    host = host or default_bind_host()
    if stop is None:
        _install_sigterm()
    zctx = zctx or zmq.Context.instance()
    rpc = zctx.socket(zmq.ROUTER)
    wire.listen_options(rpc)
    try:
        if port == 0:
            rpc.bind_to_random_port(f"tcp://{host}")
        else:
            rpc.bind(f"tcp://{host}:{port}")
    except zmq.ZMQError as exc:  # the port is taken, or the host is not an address of ours
        rpc.close(0)
        raise translate(exc, name=f"firmware {name!r} on tcp://{host}:{port}") or exc from exc
    endpoint = rpc.getsockopt_string(zmq.LAST_ENDPOINT)
    bound = int(endpoint.rsplit(":", 1)[1])
    where = f"firmware {name!r} at {endpoint}"
    drops = wire.Drops(where, log)
    refused = wire.HandshakeFailures(rpc, where, log)
    caller = token.encode() if token else None
    conn = (
        Connection(address, name, zctx, token=token, own_process=stop is None) if address else None
    )
    poller = zmq.Poller()
    poller.register(rpc, zmq.POLLIN)
    # Logged before the handshake, so that the line is in the log of every ready firmware.
    log.info("%s serving %r on %s", name, fw, endpoint)
    if conn is not None:
        poller.register(conn.socket, zmq.POLLIN)
        conn.send(wire.Hello(name, fw.period_ns, True, [], os.getpid(), bound))
    ppid = os.getppid()
    fw_seed = derive_seed(seed, name)
    try:
        while stop is None or not stop.is_set():
            events = dict(poller.poll(200 if stop is not None else _PARENT_CHECK_MS))
            if conn is not None and conn.socket in events:
                frame = wire.to_participant.decode(conn.socket.recv())
                if isinstance(frame, wire.Stop):
                    break
            if rpc in events:
                received = _receive_call(rpc, caller, drops)
                if received is None:
                    continue
                ident, request = received
                if isinstance(request, wire.Ping):
                    answer: Any = wire.Pong(request.id, name, type_name(fw.msgtype))
                else:
                    driver = RemoteDriver(conn) if conn is not None else None
                    ctx = FirmwareContext(name, fw_seed, fw.period_ns, driver)
                    ctx.time_ns = request.time_ns
                    answer = handle_call(fw, request, ctx)
                rpc.send_multipart([ident, wire.encoder.encode(answer)])
            if (
                stop is None
                and not events
                and (conn.orphaned() if conn is not None else os.getppid() != ppid)
            ):
                log.info("%s: the simulation host has gone", name)
                break
    except SimulationStopped as exc:
        log.info("%s", exc)
    finally:
        refused.close()
        rpc.close(0)
        if conn is not None:
            conn.close()


def _receive_call(
    rpc: zmq.Socket[Any], caller: bytes | None, drops: wire.Drops
) -> tuple[bytes, wire.Call | wire.Ping] | None:
    """The next call on a firmware's socket, or None if it was dropped (and why is logged)."""
    head, parts = wire.receive(rpc)
    ident = head.bytes
    if caller is not None and ident != caller:
        drops.drop(wire.describe_peer(head), "not the simulation host")
        return None
    if len(parts) != 1:
        drops.drop(wire.describe_peer(head), f"a message of {len(parts)} frames, not 1")
        return None
    try:
        request: wire.Call | wire.Ping = wire.to_firmware.decode(parts[0])
    except msgspec.DecodeError as exc:
        drops.drop(wire.describe_peer(head), f"not a call ({exc})")
        return None
    return ident, request
