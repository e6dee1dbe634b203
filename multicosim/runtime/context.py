"""What a component sees of its simulation: step contexts, topics, simulated time.

A component is written once against [`StepContext`][multicosim.runtime.context.StepContext]
(publish, subscribe, simulated time, seeded randomness) and runs unchanged in-process, in a local
process or in a container: only the link to the scheduler differs (a direct call or a ZeroMQ
socket).

Two kinds of component exist:

* a **participant** (the physics world, an injector): an object with ``period``, ``setup(ctx)``
  and ``step(ctx)``; the scheduler calls ``step`` every ``period`` of simulated time;
* a **firmware** (a controller): a function decorated with
  [`firmware`][multicosim.runtime.firmware], called with each message sent to its node; it advances
  the clock itself with ``ctx.step()`` and its return value is the reply.
"""

from __future__ import annotations

import hashlib
import logging
from typing import TYPE_CHECKING, Any, Generic, Protocol, TypeVar, runtime_checkable

from ..core.clock import NS, Delivery, to_ns
from ..core.errors import (
    MessageTypeError,
    MulticosimError,
)
from ..core.messages import type_name

if TYPE_CHECKING:
    import numpy as np

__all__ = ["FirmwareContext", "Participant", "StepContext", "Subscription", "derive_seed"]

log = logging.getLogger(__name__)

T = TypeVar("T")


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
    def fresh(self) -> bool:
        """Whether any message arrived at this step (nothing is decoded to tell)."""
        return bool(self._deliveries)

    @property
    def stamps_ns(self) -> list[int]:
        """When each of this step's messages was published (simulated ns), in their order."""
        return [d.time_ns for d in self._deliveries]

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

    def take_new_topics(self) -> list[str]:
        """The topics subscribed since last asked (for the scheduler, which routes them)."""
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

    def end_call(self) -> None:
        """Hand back the clock at the end of a call (for the runtime that made the call)."""
        if self._active and self._driver is not None:
            outbox, topics = self._take()
            self._active = False
            self._driver.deactivate(outbox, topics)
