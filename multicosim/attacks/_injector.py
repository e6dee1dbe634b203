"""The sensor injector: a participant between a sensor's raw topic and its reader.

It subscribes to ``source`` (where the world now publishes the sensor, after remapping),
corrupts each reading with its models and publishes it on ``target`` (the topic the
firmware reads). Added between world and firmware, it steps in the same instant as the world
(the scheduler steps components in add order), so it adds no delay of its own and an
injector whose models are all zero leaves the run bit-for-bit unchanged.

The same program runs wherever it is placed: in-process, as a process
(``python -m multicosim participant multicosim.attacks:injector --config JSON``), in a
container of the runtime image.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from typing import TYPE_CHECKING, Any

import msgspec

from ..core.clock import NS
from ..core.errors import ConfigurationError
from ..core.interfaces import Component, Node
from ..local import LocalEnvironment, participant_command, required_images
from ..mavlink.hil import Packer, Wire
from ..placement import ParticipantProgram, Placement, as_placement
from ..trace import ATTACK_CHANNEL
from .models import (
    Additive,
    Delay,
    Dropout,
    Model,
    Offsets,
    check_models,
    is_zero,
    subscribe_streams,
)
from .sensors import Sensor, canonical, load, module_of, sensor

if TYPE_CHECKING:
    from ..runtime.context import StepContext, Subscription

__all__ = [
    "PROGRAM",
    "AttackWindow",
    "InjectorComponent",
    "InjectorConfig",
    "SensorInjector",
    "injector",
]

PROGRAM = "multicosim.attacks:injector"
WIRES: tuple[Wire, ...] = ("native", "mavlink")


def _topic(field: str, value: object) -> str:
    if not isinstance(value, str) or not value or value != value.strip():
        raise ConfigurationError(field, value, "a non-empty topic name")
    return value


class InjectorConfig(msgspec.Struct, frozen=True, kw_only=True):
    """What one injector does: which sensor, from which topic to which, with which models.

    ``vehicle`` and ``sensor`` name the message (``"rover"``: ``position``/``gps``,
    ``magnetometer``, ``imu``, ``wheel_speed``; ``"px4"``: ``gps``, ``mag``, ``baro``,
    ``imu``; or any vehicle registered with
    [`multicosim.attacks.register`][multicosim.attacks.register], whose registering ``module`` an
    injector in another process imports); ``source`` is the raw topic read, ``target`` the topic
    written; ``period`` (s) is how often it steps (the world's publishing period, so readings pass
    in the instant they are published); ``wire`` is how PX4 payloads travel (``native`` Structs or
    packed ``mavlink`` frames). Validated on construction.
    """

    vehicle: str
    sensor: str
    source: str
    target: str
    period: float
    models: tuple[Model, ...] = ()
    wire: Wire = "native"
    module: str = ""

    def __post_init__(self) -> None:
        load(self.vehicle, self.module)
        name = canonical(self.vehicle, self.sensor)
        msgspec.structs.force_setattr(self, "sensor", name)
        if not self.module:
            msgspec.structs.force_setattr(self, "module", module_of(self.vehicle))
        _topic("source", self.source)
        _topic("target", self.target)
        if self.source == self.target:
            raise ConfigurationError(
                "target", self.target, f"a topic other than source ({self.source!r})"
            )
        period = self.period
        if (
            isinstance(period, bool)
            or not isinstance(period, int | float)
            or not math.isfinite(period)
            or not 0 < period <= 1.0
        ):
            raise ConfigurationError("period", period, "0 < period <= 1 s")
        if self.wire not in WIRES:
            raise ConfigurationError("wire", self.wire, f"one of {WIRES}")
        spec = self.spec
        if self.wire == "mavlink" and not spec.hil:
            raise ConfigurationError("wire", self.wire, f"'native' for the {self.vehicle}")
        models = check_models(
            self.models,
            {name: q.axes for name, q in spec.quantities.items()},
            spec.default,
            f"the {self.vehicle} {self.sensor} ({spec.message.__name__})",
        )
        msgspec.structs.force_setattr(self, "models", models)

    @property
    def spec(self) -> Sensor:
        """The sensor's message and quantities."""
        return sensor(self.vehicle, self.sensor)


class AttackWindow(msgspec.Struct, frozen=True, kw_only=True):
    """When a model acts on a sensor: what an injector tells a trace (``mcs/attack``)."""

    sensor: str
    model: str
    start: float
    end: float | None

    @classmethod
    def of(cls, sensor: str, model: Model) -> AttackWindow:
        """The window of ``model`` on ``sensor``."""
        return cls(sensor=sensor, model=type(model).__name__, start=model.start, end=model.end)


class SensorInjector:
    """The injector participant (see the module docstring)."""

    def __init__(self, config: InjectorConfig) -> None:
        self.config = config
        self.period = config.period
        self.sensor = config.spec
        self.passed = 0
        self.corrupted = 0
        self.dropped = 0
        self._sub: Subscription[Any] | None = None
        self._offsets: dict[str, Offsets] = {}
        by_quantity: dict[str, list[Additive]] = {}
        for model in config.models:
            if isinstance(model, Additive):
                by_quantity.setdefault(model.on or self.sensor.default, []).append(model)
        for quantity, models in by_quantity.items():
            self._offsets[quantity] = Offsets(
                models, self.sensor.quantities[quantity].axes, quantity
            )
        self._dropouts = [m for m in config.models if isinstance(m, Dropout)]
        self._delays = [m for m in config.models if isinstance(m, Delay) and m.delay > 0]
        self._held: deque[tuple[int, Any]] = deque()
        self._announced = False

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the raw topic (and to the topics of Stream models)."""
        self._sub = ctx.subscribe(self.config.source, self.sensor.payload_type(self.config.wire))
        # Its own frame numbering: what else its process packs must not change its frames.
        self._packer = Packer()
        subscribe_streams(ctx, self.config.models, self._offsets.values())

    def step(self, ctx: StepContext) -> None:
        """Corrupt what arrived since the last step; publish what is due."""
        sub = self._sub
        assert sub is not None, "setup() was not called"
        if not self._announced:
            # Once, for traces: when each model acts (the plot marks the windows).
            self._announced = True
            for model in self.config.models:
                if not is_zero(model):
                    ctx.publish(ATTACK_CHANNEL, AttackWindow.of(self.config.sensor, model))
        if sub.fresh:
            # Each reading is judged at the time it was published, not at this step.
            for stamp, payload in zip(sub.stamps_ns, sub.messages, strict=True):
                self._receive(stamp, payload, ctx)
        held = self._held
        while held and held[0][0] <= ctx.time_ns:
            ctx.publish(self.config.target, held.popleft()[1])

    def _receive(self, time_ns: int, payload: Any, ctx: StepContext) -> None:
        time = time_ns / NS
        if any(m.active(time) for m in self._dropouts):
            self.dropped += 1
            return
        out = payload
        if self._offsets:
            message = self.sensor.read(payload)
            if message is not None:
                changed = message
                for quantity, offsets in self._offsets.items():
                    delta = offsets.at(time, ctx.rng)
                    if delta is not None and any(delta):
                        changed = self.sensor.apply(changed, quantity, delta)
                if changed is not message:
                    out = self.sensor.write(changed, self.config.wire, self._packer)
                    self.corrupted += 1
        delay = max((m.delay for m in self._delays if m.active(time)), default=0.0)
        if delay > 0 or self._held:
            # Held readings leave in order: one never overtakes an earlier one.
            release = time_ns + round(delay * NS)
            if self._held:
                release = max(release, self._held[-1][0])
            self._held.append((release, out))
            return
        self.passed += 1
        ctx.publish(self.config.target, out)


def injector(config: InjectorConfig) -> SensorInjector:
    """Factory of the injector program (``multicosim participant multicosim.attacks:injector``)."""
    return SensorInjector(config)


@dataclasses.dataclass(frozen=True)
class InjectorComponent:
    """The injector as a component, run where ``placement`` says: this process (default),
    a local process (``"process"``), a container (``"docker"``) or any registered placement.
    """

    config: InjectorConfig
    name: str = "injector"
    placement: str | Placement = "in-process"

    def __post_init__(self) -> None:
        if not isinstance(self.config, InjectorConfig):
            raise ConfigurationError("config", self.config, "a multicosim.attacks.InjectorConfig")
        if not isinstance(self.name, str) or not self.name:
            raise ConfigurationError("name", self.name, "a non-empty component name")
        as_placement(self.placement)

    @property
    def command(self) -> list[str]:
        """The injector program's command line (after ``python -m``)."""
        return participant_command(PROGRAM, self.config)

    def _placed(self) -> Component[Any, Node]:
        program = ParticipantProgram(PROGRAM, self.config, self.name)
        return as_placement(self.placement).participant(program)

    def required_images(self) -> tuple[str, ...]:
        """The images its placement needs (checked before a run that runs containers starts)."""
        return tuple(required_images(self._placed()))

    def start(self, environment: LocalEnvironment) -> Node:
        """Start the injector where it is placed."""
        return self._placed().start(environment)
