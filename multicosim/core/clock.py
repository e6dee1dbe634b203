"""The lockstep scheduler: one simulated clock, topics routed in a fixed order.

Design (see docs/concepts/architecture.md): a central scheduler steps participants one at a time in
order of their next wake-up time, ties broken by the order they were added to the simulator.
Messages published during a step are routed at once, so a participant added later sees, in the
same instant, what an earlier one published (an injector placed between a sensor and its reader
adds no delay). Simulated time advances only while a *driver* (a firmware handler, or the host
advancing the clock) is active; the physics world and injectors are passive.

The scheduler is run by whichever thread waits for the simulation: the host thread inside
``send`` or ``advance``, or an in-process firmware inside ``ctx.step()``. No extra thread is
involved, so in-process runs cost only function calls.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from typing import Any, Protocol, TypeVar, runtime_checkable

import msgspec

from .errors import ConfigurationError, MulticosimError
from .messages import decode, encode

__all__ = [
    "Clocked",
    "Delivery",
    "Link",
    "Member",
    "Scheduler",
    "StepResult",
    "Wrapper",
    "find_scheduler",
    "to_ns",
]

T = TypeVar("T")
NS = 1_000_000_000


def to_ns(seconds: float, *, field: str = "period") -> int:
    """Convert seconds to integer nanoseconds (simulated time is kept exact in integers)."""
    if not seconds > 0 or seconds != seconds:
        raise ConfigurationError(field, seconds, "a positive number of seconds")
    return round(seconds * NS)


# A Struct rather than a slotted class: built for every published message, it is four
# times cheaper to create, and gc=False keeps it out of the cyclic collector, so recording
# every message (trace taps keep them all) adds no collector work for the deliveries. It holds
# only strings, integers, bytes and a message, never anything that refers back to it, so it
# cannot be part of a reference cycle.
class Delivery(msgspec.Struct, gc=False, eq=False):
    """One published message; encoded or decoded lazily so local hops skip serialization.

    ``obj`` is the message as published in this process (None when it came over a socket),
    ``raw`` its MessagePack encoding once known; ``source`` names the publisher.
    """

    topic: str
    time_ns: int
    obj: object = None
    raw: bytes | None = None
    source: str = ""

    @property
    def data(self) -> bytes:
        """The MessagePack encoding of the message."""
        if self.raw is None:
            self.raw = encode(self.obj)
        return self.raw

    def as_type(self, tp: type[T]) -> T:
        """The message as ``tp``: the object itself when it is one, else decoded and checked."""
        obj = self.obj
        if obj is not None and type(obj) is tp:
            return obj
        return decode(self.data, tp, what=f"message on topic {self.topic!r}")


class StepResult(msgspec.Struct, gc=False):
    """What a participant hands back after a step."""

    next_ns: int | None
    outbox: list[Delivery]
    subscribe: list[str] = []


class Link(Protocol):
    """How the scheduler reaches a participant: a direct call or a socket exchange."""

    def step(self, member: Member, time_ns: int, inbox: list[Delivery]) -> StepResult:
        """Run ``member``'s step at ``time_ns`` with ``inbox``; return what it yields."""
        ...


class Member:
    """The scheduler's record of one participant."""

    __slots__ = ("drives", "inbox", "link", "name", "next_ns", "order", "subscriptions")

    def __init__(
        self, name: str, order: int, link: Link | None, *, drives: bool, next_ns: int | None
    ) -> None:
        self.name = name
        self.order = order
        self.link = link
        self.drives = drives
        self.next_ns = next_ns
        self.inbox: list[Delivery] = []
        self.subscriptions: set[str] = set()

    def __repr__(self) -> str:
        return f"Member({self.name!r}, order={self.order}, next_ns={self.next_ns})"


class Scheduler:
    """Steps members in (next wake-up, add order) order and routes their messages.

    ``realtime`` paces simulated time to wall time (``1.0`` real time, ``2.0`` twice as fast);
    ``None`` runs as fast as the participants compute.
    """

    def __init__(self, *, realtime: float | None = None) -> None:
        if realtime is not None and not realtime > 0:
            raise ConfigurationError("realtime", realtime, "None or a positive speed factor")
        self.realtime = realtime
        self.now_ns = 0
        self._members: list[Member] = []
        self._by_name: dict[str, Member] = {}
        self._subscribers: dict[str, list[Member]] = {}
        self._latched: dict[str, Delivery] = {}
        self._active_drivers = 0
        self._holds = 0
        self._lock = threading.RLock()
        self._pace_anchor: tuple[float, int] | None = None
        self.closed = False
        # Subscribers of every topic, called with each routed message (trace recorders).
        self.taps: list[Callable[[Delivery], None]] = []

    # -- membership ---------------------------------------------------------------------

    def add(self, member: Member) -> Member:
        """Register ``member``; its ``order`` fixes its place among same-instant steps."""
        with self._lock:
            if member.name in self._by_name:
                raise ConfigurationError(
                    "name", member.name, "a name not used by another component"
                )
            self._members.append(member)
            self._members.sort(key=lambda m: m.order)
            self._by_name[member.name] = member
            if member.drives and member.next_ns is not None:
                self._active_drivers += 1
            return member

    def member(self, name: str) -> Member:
        """The member called ``name``."""
        return self._by_name[name]

    @property
    def members(self) -> list[Member]:
        """Members in add order."""
        return list(self._members)

    @property
    def time(self) -> float:
        """The current simulated time in seconds."""
        return self.now_ns / 1e9

    @property
    def running(self) -> bool:
        """True while some driver (or host hold) keeps simulated time moving."""
        return self._active_drivers > 0 or self._holds > 0

    def subscribe(self, member: Member, topics: Iterable[str]) -> None:
        """Subscribe ``member`` to ``topics``; a new subscriber gets each topic's last message."""
        for topic in topics:
            if topic in member.subscriptions:
                continue
            member.subscriptions.add(topic)
            self._subscribers.setdefault(topic, []).append(member)
            self._subscribers[topic].sort(key=lambda m: m.order)
            latched = self._latched.get(topic)
            if latched is not None and latched.source != member.name:
                member.inbox.append(latched)

    def activate(self, member: Member, subscribe: Iterable[str] = ()) -> None:
        """Schedule driver ``member`` from the current instant, with the topics' last values."""
        if member.next_ns is not None:
            raise MulticosimError(f"component {member.name!r} is already active")
        member.next_ns = self.now_ns
        if member.drives:
            self._active_drivers += 1
        # A driver idle until now missed the traffic: hand it the latest value of each topic.
        member.inbox = [
            self._latched[t]
            for t in sorted(member.subscriptions)
            if t in self._latched and self._latched[t].source != member.name
        ]
        self.subscribe(member, subscribe)

    # -- stepping -----------------------------------------------------------------------

    def next_member(self) -> Member | None:
        """The member to step next, or None when nobody is scheduled."""
        best: Member | None = None
        for m in self._members:
            if m.next_ns is not None and (best is None or m.next_ns < best.next_ns):  # type: ignore[operator]
                best = m
        return best

    def step_member(self, member: Member) -> None:
        """Step ``member`` now (it must be the next one) through its link."""
        assert member.next_ns is not None
        assert member.link is not None
        time_ns = member.next_ns
        if self.realtime is not None:
            self._pace(time_ns)
        self.now_ns = time_ns
        inbox, member.inbox = member.inbox, []
        result = member.link.step(member, time_ns, inbox)
        self.finish(member, result)

    def finish(self, member: Member, result: StepResult) -> None:
        """Apply a step's result: new subscriptions, routing, rescheduling."""
        if result.subscribe:
            self.subscribe(member, result.subscribe)
        if result.outbox:
            self.route(member, result.outbox)
        next_ns = result.next_ns
        if next_ns is not None and next_ns <= self.now_ns:
            next_ns = self.now_ns + 1
        was_active = member.next_ns is not None
        member.next_ns = next_ns
        if member.drives and was_active and next_ns is None:
            self._active_drivers -= 1

    def route(self, source: Member, outbox: list[Delivery]) -> None:
        """Deliver ``outbox`` (published by ``source`` now) to every subscriber."""
        now = self.now_ns
        for d in outbox:
            d.time_ns = now
            d.source = source.name
            self._latched[d.topic] = d
            for sub in self._subscribers.get(d.topic, ()):
                # An idle driver is not listening; it gets the latched value on activation.
                if sub is not source and (sub.next_ns is not None or not sub.drives):
                    sub.inbox.append(d)
            for tap in self.taps:
                tap(d)

    def run(
        self,
        until: Callable[[], bool],
        *,
        idle: Callable[[], None],
        between: Callable[[], None] | None = None,
    ) -> None:
        """Step members until ``until()`` holds.

        While no driver is active, ``idle()`` is called instead (it waits for something to
        happen: a driver activating, a reply arriving, and raises on timeout or crash).
        ``between()`` is called between steps for cheap liveness checks.
        """
        while not until():
            if self.closed:
                raise MulticosimError("the simulation was stopped")
            if self._active_drivers > 0 or self._holds > 0:  # self.running, inlined
                member = self.next_member()
                if member is None:
                    idle()
                    continue
                self.step_member(member)
                if between is not None:
                    between()
            else:
                self._pace_anchor = None
                idle()

    def advance(self, duration_ns: int) -> None:
        """Run every step due before ``now + duration_ns``, whether or not a driver is active.

        Afterwards the clock reads ``now + duration_ns``; steps due exactly then are next.
        """
        target = self.now_ns + duration_ns
        with self.hold():
            while True:
                member = self.next_member()
                if member is None or member.next_ns >= target:  # type: ignore[operator]
                    break
                self.step_member(member)
        self.now_ns = max(self.now_ns, target)

    def hold(self) -> _Hold:
        """Context manager keeping the clock running (the host acting as a driver)."""
        return _Hold(self)

    def _pace(self, time_ns: int) -> None:
        assert self.realtime is not None
        now_wall = time.monotonic()
        if self._pace_anchor is None:
            self._pace_anchor = (now_wall, time_ns)
            return
        wall0, sim0 = self._pace_anchor
        due = wall0 + (time_ns - sim0) / 1e9 / self.realtime
        if due > now_wall:
            time.sleep(due - now_wall)

    def lock(self) -> threading.RLock:
        """The lock serializing threads that run the scheduler."""
        return self._lock


class _Hold:
    def __init__(self, scheduler: Scheduler) -> None:
        self._scheduler = scheduler

    def __enter__(self) -> None:
        self._scheduler._holds += 1

    def __exit__(self, *exc: Any) -> None:
        self._scheduler._holds -= 1


@runtime_checkable
class Clocked(Protocol):
    """A simulation on a simulated clock (a local or container simulation, a scenario's):
    ``scheduler`` is the clock its components step on, which traces and checks tap."""

    @property
    def scheduler(self) -> Scheduler:
        """The simulated clock."""
        ...


@runtime_checkable
class Wrapper(Protocol):
    """A simulation of one's own built on another (``simulation`` is the one it wraps), as a
    scenario's simulation is built on its simulator's."""

    simulation: object


def find_scheduler(simulation: object) -> Scheduler:
    """The scheduler of ``simulation``: a Scheduler itself, a ``Clocked`` simulation's, or
    that of the simulation a ``Wrapper`` wraps."""
    seen: set[int] = set()
    while id(simulation) not in seen:
        seen.add(id(simulation))
        if isinstance(simulation, Scheduler):
            return simulation
        if isinstance(simulation, Clocked):
            return simulation.scheduler
        if not isinstance(simulation, Wrapper):
            break
        simulation = simulation.simulation
    raise ConfigurationError(
        "simulation",
        simulation,
        "a simulation with a simulated clock (ProcessSimulation, ContainerSimulation, a "
        "scenario's simulation, or anything with a .scheduler)",
    )
