"""Fault and attack models of the sensor injector: what each does to a reading, and when.

Every model is a frozen msgspec Struct (a configuration that travels as JSON to an injector
process), validated on construction, and active from ``start`` until ``end`` (simulated
seconds; ``end=None``: to the end of the run). Additive models
([`Gaussian`][multicosim.attacks.models.Gaussian], [`Bias`][multicosim.attacks.models.Bias],
[`Drift`][multicosim.attacks.models.Drift], [`Jump`][multicosim.attacks.models.Jump], and
[`Stream`][multicosim.attacks.models.Stream], whose offset another component computes) change one
quantity of the reading (``on``; None: the sensor's default, e.g. the GPS position); a value is a
number (the same on every axis), a [`Local`][multicosim.attacks.models.Local] for a position's axes
by name (``Local(north=4.0)``: 4 m north), or one number per axis in the quantity's own order (body
axes x, y, z; a plain tuple for a position is deprecated: its order, east/north/up, is easy to get
wrong). [`Dropout`][multicosim.attacks.models.Dropout] and
[`Delay`][multicosim.attacks.models.Delay] act on whole messages. Random models draw from the
injector's seeded generator (``ctx.rng``), so a seed gives the same corrupted readings every time.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol, Union

import msgspec

from ..core.errors import ConfigurationError

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "Additive",
    "Bias",
    "Delay",
    "Drift",
    "Dropout",
    "Gaussian",
    "Jump",
    "Local",
    "Model",
    "Stream",
    "Value",
    "Window",
    "is_zero",
]


class Latest(Protocol):
    """Where a Stream's latest value is read (a Subscription)."""

    @property
    def latest(self) -> Any: ...


class Local(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """A value per axis of a local position, by name: north, east, up (0 where not given).

    The units are the quantity's (m for a GPS position, m/s for a velocity, ...):

    ```python
    attacks.Jump(offset=attacks.Local(north=4.0), start=3.0)  # 4 m north from t=3 s
    ```
    """

    north: float = 0.0
    east: float = 0.0
    up: float = 0.0

    def __post_init__(self) -> None:
        for name in AXES:
            _finite(name, getattr(self, name), "a finite number")


AXES = ("north", "east", "up")
"""The axes a [`Local`][multicosim.attacks.models.Local] names."""

# A number for every axis, one number per axis, or a local position's axes by name.
Value = Union[float, tuple[float, ...], Local]  # noqa: UP007 - msgspec reads this at run time


class Named(tuple[float, ...]):
    """Per-axis values that carry their axes' names (from a
    [`Local`][multicosim.attacks.models.Local])."""

    names: tuple[str, ...] = AXES


def _finite(field: str, value: object, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigurationError(field, value, allowed)
    return float(value)


def _values(field: str, value: object, *, non_negative: bool = False) -> tuple[float, ...]:
    sign = ">= 0" if non_negative else ""
    allowed = f"a finite number {sign} or a tuple of them, one per axis".replace("  ", " ")
    if isinstance(value, Local):
        named = Named(getattr(value, name) for name in AXES)
        if non_negative and any(v < 0 for v in named):
            raise ConfigurationError(field, value, allowed)
        return named
    items = value if isinstance(value, tuple | list) else (value,)
    if not items:
        raise ConfigurationError(field, value, allowed)
    out = tuple(_finite(field, v, allowed) for v in items)
    if non_negative and any(v < 0 for v in out):
        raise ConfigurationError(field, value, allowed)
    return out


class Window(msgspec.Struct, frozen=True, kw_only=True):
    """When a model acts: from ``start`` (s) until ``end`` (s, exclusive; None: forever)."""

    start: float = 0.0
    end: float | None = None

    def __post_init__(self) -> None:
        start = _finite("start", self.start, "a time >= 0 s")
        if start < 0:
            raise ConfigurationError("start", self.start, "a time >= 0 s")
        if self.end is not None:
            end = _finite("end", self.end, f"None or a time > start ({start:g} s)")
            if end <= start:
                raise ConfigurationError("end", self.end, f"None or a time > start ({start:g} s)")

    def active(self, time: float) -> bool:
        """Whether the model acts at simulated ``time``."""
        return self.start <= time and (self.end is None or time < self.end)


class Additive(Window, frozen=True, kw_only=True):
    """A model that adds an offset to one quantity of the reading (``on``)."""

    on: str | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.on is not None and (not isinstance(self.on, str) or not self.on):
            raise ConfigurationError("on", self.on, "None or a quantity name")

    def vectors(self) -> dict[str, tuple[float, ...]]:
        """The model's per-axis parameters by field name (checked against the quantity)."""
        return {}


class Gaussian(Additive, frozen=True, kw_only=True, tag="gaussian"):
    """White noise: ``mean + std * N(0, 1)`` drawn afresh for every reading."""

    std: Value = 1.0
    mean: Value = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _values("std", self.std, non_negative=True)
        _values("mean", self.mean)

    def vectors(self) -> dict[str, tuple[float, ...]]:
        """Standard deviation and mean per axis."""
        return {"std": _values("std", self.std), "mean": _values("mean", self.mean)}


class Bias(Additive, frozen=True, kw_only=True, tag="bias"):
    """A constant offset."""

    offset: Value = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _values("offset", self.offset)

    def vectors(self) -> dict[str, tuple[float, ...]]:
        """The offset per axis."""
        return {"offset": _values("offset", self.offset)}


class Drift(Additive, frozen=True, kw_only=True, tag="drift"):
    """A random walk: grows by ``rate * dt + std * sqrt(dt) * N(0, 1)`` between readings.

    ``std`` is in units per square-root second, ``rate`` in units per second. The walk
    starts from zero at ``start`` and is gone after ``end``.
    """

    std: Value = 0.0
    rate: Value = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _values("std", self.std, non_negative=True)
        _values("rate", self.rate)

    def vectors(self) -> dict[str, tuple[float, ...]]:
        """Diffusion and rate per axis."""
        return {"std": _values("std", self.std), "rate": _values("rate", self.rate)}


class Jump(Additive, frozen=True, kw_only=True, tag="jump"):
    """A spoof: ``offset`` appears at ``start``, reached linearly over ``ramp`` seconds."""

    offset: Value = 0.0
    ramp: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _values("offset", self.offset)
        ramp = _finite("ramp", self.ramp, "a duration >= 0 s")
        if ramp < 0:
            raise ConfigurationError("ramp", self.ramp, "a duration >= 0 s")

    def vectors(self) -> dict[str, tuple[float, ...]]:
        """The full offset per axis."""
        return {"offset": _values("offset", self.offset)}


class Stream(Additive, frozen=True, kw_only=True, tag="stream"):
    """An offset another component computes: the latest value published on ``topic`` (one
    number for every axis, or one per axis), times ``scale``; none before the first.

    The component (an FMU modelling the environment, a controller of your own) publishes
    as it steps; the injector adds its latest value to each reading, so an environment
    model runs at its own rate beside the world's sensors.
    """

    topic: str = ""
    scale: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.topic, str) or not self.topic or self.topic != self.topic.strip():
            raise ConfigurationError("topic", self.topic, "a non-empty topic name")
        _finite("scale", self.scale, "a finite number")


class Dropout(Window, frozen=True, kw_only=True, tag="dropout"):
    """No reading at all while active (a lost fix, a dead sensor)."""


class Delay(Window, frozen=True, kw_only=True, tag="delay"):
    """Readings taken while active reach the firmware ``delay`` seconds late (in order)."""

    delay: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        delay = _finite("delay", self.delay, "a duration >= 0 s")
        if delay < 0:
            raise ConfigurationError("delay", self.delay, "a duration >= 0 s")


Model = Union[Gaussian, Bias, Drift, Jump, Stream, Dropout, Delay]  # noqa: UP007 - tagged union
MODEL_TYPES: tuple[type[Window], ...] = (Gaussian, Bias, Drift, Jump, Stream, Dropout, Delay)
# What a Stream's topic carries: one number for every axis, or one per axis.
StreamValue = Union[float, list[float]]  # noqa: UP007 - msgspec reads this alias at run time


def is_zero(model: Model) -> bool:
    """Whether ``model`` leaves every reading as it is (all offsets, noise and delay zero)."""
    if isinstance(model, Dropout):
        return False
    if isinstance(model, Delay):
        return model.delay == 0.0
    if isinstance(model, Stream):
        return model.scale == 0.0
    return all(v == 0.0 for vector in model.vectors().values() for v in vector)


def check_models(
    models: object, quantities: Mapping[str, tuple[str, ...]], default: str, what: str
) -> tuple[Model, ...]:
    """``models`` as a tuple; ConfigurationError naming the first one that does not fit.

    ``quantities`` maps each quantity an additive model may act on (``on``, else
    ``default``) to its axes' names; ``what`` names the sensor in errors. A plain tuple of
    values for a local position's axes is accepted with a DeprecationWarning (a
    [`Local`][multicosim.attacks.models.Local] names them).
    """
    if isinstance(models, list):
        models = tuple(models)
    if not isinstance(models, tuple):
        raise ConfigurationError("models", models, "a sequence of attack models")
    for i, model in enumerate(models):
        if not isinstance(model, MODEL_TYPES):
            names = ", ".join(t.__name__ for t in MODEL_TYPES)
            raise ConfigurationError(f"models[{i}]", model, f"one of {names}")
        if isinstance(model, Additive):
            quantity = model.on or default
            if quantity not in quantities:
                raise ConfigurationError(
                    f"models[{i}].on",
                    model.on,
                    f"a quantity of {what}: one of {tuple(quantities)}",
                )
            axes = quantities[quantity]
            for field, values in model.vectors().items():
                broadcast(f"models[{i}].{field}", values, axes, quantity)
                if len(values) > 1 and not isinstance(values, Named) and set(AXES) <= set(axes):
                    warnings.warn(
                        f"models[{i}].{field}={tuple(values)}: a tuple gives the axes of "
                        f"{quantity!r} in the order {axes}, which is easy to get wrong; give "
                        "attacks.Local(north=..., east=..., up=...) instead",
                        DeprecationWarning,
                        stacklevel=4,
                    )
    return models


def subscribe_streams(ctx: Any, models: Sequence[Model], offsets: Iterable[Offsets]) -> None:
    """Subscribe ``ctx`` (a StepContext) to the topics of the
    [`Stream`][multicosim.attacks.models.Stream] models and hand the subscriptions to ``offsets``
    (in a participant's ``setup``)."""
    streams = {
        m.topic: ctx.subscribe(m.topic, StreamValue) for m in models if isinstance(m, Stream)
    }
    for each in offsets:
        each.streams = streams


def broadcast(
    field: str, values: Sequence[float], axes: tuple[str, ...], quantity: str
) -> tuple[float, ...]:
    """``values`` (one number, one per axis, or named axes) as one number per axis of
    ``axes``, in their order; raise if it cannot be."""
    size = len(axes)
    if isinstance(values, Named):
        # A Local names north, east and up, 0 where not given: it fits a quantity with any
        # of those axes (a two-axis position), as long as it gives nothing to the others.
        by_name = dict(zip(values.names, values, strict=True))
        given = ", ".join(f"{n}={v:g}" for n, v in by_name.items() if v != 0.0)
        if any(a not in by_name for a in axes) or any(
            v != 0.0 for n, v in by_name.items() if n not in axes
        ):
            raise ConfigurationError(
                field, f"Local({given})", f"values for the axes of {quantity!r}: {axes}"
            )
        return tuple(by_name[axis] for axis in axes)
    if len(values) == size:
        return tuple(values)
    if len(values) == 1:
        return tuple(values) * size
    raise ConfigurationError(
        field, tuple(values), f"one number or {size} (one per axis of {quantity!r})"
    )


class Offsets:
    """The run-time state of the additive models on one quantity (random walks, ...).

    ``streams`` gives the latest value of each [`Stream`][multicosim.attacks.models.Stream] model's
    topic (the injector's subscriptions).
    """

    def __init__(self, models: Sequence[Additive], axes: tuple[str, ...], quantity: str) -> None:
        self.axes = axes
        self.size = len(axes)
        self.quantity = quantity
        self.streams: Mapping[str, Latest] = {}
        self._models = list(models)
        self._params = [
            {k: broadcast(k, v, axes, quantity) for k, v in m.vectors().items()} for m in models
        ]
        self._walk: list[list[float] | None] = [None] * len(models)
        self._walk_time: list[float] = [0.0] * len(models)

    def at(self, time: float, rng: np.random.Generator) -> list[float] | None:
        """The summed offset at ``time`` (None when every model is inactive or zero)."""
        total: list[float] | None = None
        for i, (model, p) in enumerate(zip(self._models, self._params, strict=True)):
            if not model.active(time):
                self._walk[i] = None  # a walk restarts from zero if its window reopens
                continue
            delta = self._offset(i, model, p, time, rng)
            if delta is None:
                continue
            total = delta if total is None else [a + b for a, b in zip(total, delta, strict=True)]
        return total

    def _offset(
        self,
        i: int,
        model: Additive,
        p: dict[str, tuple[float, ...]],
        time: float,
        rng: np.random.Generator,
    ) -> list[float] | None:
        if isinstance(model, Gaussian):
            std, mean = p["std"], p["mean"]
            if not any(std):
                return list(mean) if any(mean) else None
            draws = rng.standard_normal(self.size).tolist()
            return [m + s * d for m, s, d in zip(mean, std, draws, strict=True)]
        if isinstance(model, Bias):
            return list(p["offset"]) if any(p["offset"]) else None
        if isinstance(model, Stream):
            source = self.streams.get(model.topic)
            value = source.latest if source is not None else None
            if value is None:
                return None
            given = tuple(value) if isinstance(value, list | tuple) else (value,)
            what = f"the value on {model.topic!r}"
            return [model.scale * v for v in broadcast(what, given, self.axes, self.quantity)]
        if isinstance(model, Jump):
            offset = p["offset"]
            if not any(offset):
                return None
            scale = 1.0 if model.ramp == 0.0 else min(1.0, (time - model.start) / model.ramp)
            return [scale * v for v in offset]
        assert isinstance(model, Drift)
        std, rate = p["std"], p["rate"]
        if not any(std) and not any(rate):
            return None
        walk = self._walk[i]
        if walk is None:
            walk = self._walk[i] = [0.0] * self.size
        else:
            dt = time - self._walk_time[i]
            root = math.sqrt(max(dt, 0.0))
            draws = rng.standard_normal(self.size).tolist() if any(std) else [0.0] * self.size
            for k in range(self.size):
                walk[k] += rate[k] * dt + std[k] * root * draws[k]
        self._walk_time[i] = time
        return list(walk)
