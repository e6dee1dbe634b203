"""The component side of the lockstep: how a component's steps reach the scheduler.

A component in its own process talks to the coordinator over ZeroMQ (``Connection``,
``RemoteDriver``), watching its host so that it dies with it (``HostWatch``); one in
the simulation's process is stepped by direct calls (``LocalDriver``,
``LocalParticipantLink``). Either way the component sees the same
[`StepContext`][multicosim.StepContext].
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from typing import TYPE_CHECKING, Any

from ..core import wire
from ..core.clock import Delivery, Member, Scheduler, StepResult, to_ns
from ..core.errors import (
    MulticosimError,
    NodeTimeoutError,
    SimulationStopped,
)
from .context import Participant, StepContext

if TYPE_CHECKING:
    import zmq

log = logging.getLogger(__name__)

# How often a waiting component checks that its parent still exists, so that a component
# whose host was killed exits instead of lingering.
_PARENT_CHECK_MS = 1000


# -- remote link ----------------------------------------------------------------------------


class Connection:
    """A component's socket to the coordinator (a DEALER whose identity is its token).

    ``own_process``: this process is the component (not a thread of the host), so it must
    end when the host has gone, even in the middle of a step (see ``HostWatch``).
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

    After ``limit``, the handler may take that long in wall time between two of its
    steps (the time it takes the simulation to make progress), however long it runs in all:
    a step after a longer wait raises NodeTimeoutError, and ``deadline`` moves on with
    every step.
    """

    def __init__(self, scheduler: Scheduler, member: Member) -> None:
        self.scheduler = scheduler
        self.member = member
        self.deadline = math.inf
        self.timeout = math.inf

    def limit(self, timeout: float) -> float:
        """Give the handler ``timeout`` wall-clock seconds from now, and as long again from
        each of its steps; return the first deadline."""
        self.timeout = timeout
        self.deadline = time.monotonic() + timeout
        return self.deadline

    def _my_turn(self) -> tuple[int, list[Delivery]]:
        # Scheduler.run specialised to "until it is my turn": this driver is active, so the
        # clock runs, and the next member is found once per step instead of twice.
        now = time.monotonic()
        if now > self.deadline:
            raise NodeTimeoutError(
                self.member.name,
                f"did not answer within {self.timeout:g} s of its last step (at "
                f"t={self.scheduler.now_ns / 1e9:g} s of simulated time)",
            )
        # Liveness, not a bound on the whole call: the handler is stepping, so it has until
        # as long again from now.
        self.deadline = now + self.timeout
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
