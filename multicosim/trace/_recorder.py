"""The recorder: a scheduler tap that keeps every routed message, written only when saved."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import msgspec

from ..core.clock import find_scheduler
from ..core.errors import ConfigurationError, TraceError
from ..core.files import replacing
from ._convert import (
    PLAN_CHANNEL,
    ROBUSTNESS_CHANNEL,
    TRAJECTORY_CHANNEL,
    Converter,
    TraceOptions,
    trace_options,
)
from ._mcap import Row, write_mcap
from ._schemas import (
    ANY_OBJECT,
    PLAN,
    ROBUSTNESS,
    WRAPPED,
    Schema,
    is_array_like,
    schema_for,
    signals_schema,
)
from ._tlog import write_tlog

if TYPE_CHECKING:
    from ..core.clock import Delivery, Scheduler
    from ..core.signals import Signals

__all__ = ["PLAN_CHANNEL", "ROBUSTNESS_CHANNEL", "TRAJECTORY_CHANNEL", "Recorder"]


class Evaluated(Protocol):
    """What a trace keeps of a requirement's evaluation
    ([`multicosim.search.requirements.Evaluation`][multicosim.search.requirements.Evaluation] is
    one)."""

    @property
    def formula(self) -> str: ...
    @property
    def robustness(self) -> float: ...
    @property
    def worst_time(self) -> float: ...
    @property
    def values(self) -> Mapping[str, float]: ...
    @property
    def predicate(self) -> str: ...
    @property
    def series(self) -> tuple[tuple[float, float], ...]: ...
    @property
    def first_violation(self) -> float | None: ...
    def explain(self) -> str:
        """A one-paragraph account of the verdict."""
        ...


@dataclasses.dataclass
class _Extra:
    channel: str
    time_ns: int
    message: Any
    schema: Schema | None


class Recorder:
    """Records the messages of a simulation, and extras (trajectory, plan, robustness).

    ``types`` maps topics to message types (schemas, and typing messages that arrive as
    MessagePack from processes); ``converters`` derive Foxglove well-known channels;
    ``metadata`` goes into the trace's metadata record. A simulation's ``trace_options()``
    add to them when the recorder is attached.
    """

    def __init__(
        self,
        *,
        types: Mapping[str, Any] | None = None,
        converters: Sequence[Converter] = (),
        metadata: Mapping[str, object] | None = None,
    ) -> None:
        self.types = dict(types or {})
        self.converters = list(converters)
        # What was given here, before a simulation's trace options add to it.
        self._given = (dict(self.types), list(self.converters))
        self.metadata: dict[str, object] = dict(metadata or {})
        self.options = TraceOptions()
        self.deliveries: list[Delivery] = []
        # Topic -> schema name of the last trace written (what a layout can show).
        self.channels: dict[str, str] = {}
        self._extras: list[_Extra] = []
        self._scheduler: Scheduler | None = None
        self._tap: Callable[[Delivery], None] | None = None

    # -- recording (hot path: one list append per routed message) ---------------------------

    def attach(self, simulation: object) -> Recorder:
        """Record every message routed in ``simulation`` from now on; returns self."""
        if self._scheduler is not None:
            raise TraceError("this recorder is already attached to a simulation")
        scheduler = find_scheduler(simulation)
        self.use_options(simulation)
        # The bound method itself is the tap: no Python frame of ours runs per message.
        self._tap = self.deliveries.append
        scheduler.taps.append(self._tap)
        self._scheduler = scheduler
        return self

    def use_options(self, simulation: object) -> None:
        """Convert and lay out what is recorded as ``simulation``'s trace options say.

        ``attach`` does it; a scenario's simulation wrapping the one recorded (its channels,
        converters, plan and plots) does it again.
        """
        options = trace_options(simulation)
        given_types, given_converters = self._given
        self.options = options
        self.types = {**options.types, **given_types}
        self.converters = [*options.converters, *given_converters]
        if options.plan and not any(e.channel == PLAN_CHANNEL for e in self._extras):
            self.add_plan(options.plan)

    def detach(self) -> None:
        """Stop recording (the recorded messages stay); idempotent."""
        if self._scheduler is not None and self._tap is not None:
            with contextlib.suppress(ValueError):
                self._scheduler.taps.remove(self._tap)
        self._scheduler = None
        self._tap = None

    @property
    def attached(self) -> bool:
        """Whether it is recording a simulation now."""
        return self._scheduler is not None

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.detach()

    def __len__(self) -> int:
        return len(self.deliveries) + len(self._extras)

    # -- extras ---------------------------------------------------------------------------

    def add(
        self, channel: str, time: float, message: object, *, schema: Schema | None = None
    ) -> None:
        """Record ``message`` on ``channel`` at simulated ``time`` (a reply, an event, ...)."""
        self._extras.append(_Extra(channel, _ns(time), message, schema))

    def add_trajectory(
        self,
        trajectory: object,
        *,
        times: Sequence[float] | None = None,
        channel: str = TRAJECTORY_CHANNEL,
    ) -> None:
        """Record a trajectory (a firmware's reply) as one message per sample, at its time."""
        from ..core.signals import signals_of

        self.add_signals(signals_of(trajectory, times=times), channel)

    def add_signals(self, signals: Signals, channel: str = TRAJECTORY_CHANNEL) -> None:
        """Record columns of signals (replacing what ``channel`` held)."""
        self._extras = [e for e in self._extras if e.channel != channel]
        names = list(signals.columns)
        schema = signals_schema(names)
        rows = zip(*(signals.columns[n].tolist() for n in names), strict=True)
        for t, row in zip(signals.times.tolist(), rows, strict=True):
            message = {"time": t, **{n: _json_float(v) for n, v in zip(names, row, strict=True)}}
            self._extras.append(_Extra(channel, _ns(t), message, schema))

    def add_plan(
        self, points: Sequence[Sequence[float]], *, time: float = 0.0, channel: str = PLAN_CHANNEL
    ) -> None:
        """Record the planned path: points (east, north[, up]) in the local frame, in metres."""
        path = [
            {"east": float(p[0]), "north": float(p[1]), "up": float(p[2]) if len(p) > 2 else 0.0}
            for p in points
        ]
        self._extras = [e for e in self._extras if e.channel != channel]
        self._extras.append(_Extra(channel, _ns(time), {"points": path}, PLAN))

    def add_evaluation(
        self,
        evaluation: Evaluated,
        series: Sequence[tuple[float, float]] = (),
        *,
        channel: str = ROBUSTNESS_CHANNEL,
    ) -> None:
        """Record a requirement's robustness (over time when ``series`` is given)."""
        self._extras = [e for e in self._extras if e.channel != channel]
        points = list(series) or list(evaluation.series)
        points = points or [(evaluation.worst_time, evaluation.robustness)]
        for t, margin in points:
            message = {
                "formula": evaluation.formula,
                "robustness": _json_float(evaluation.robustness),
                "margin": _json_float(margin),
                "predicate": evaluation.predicate,
            }
            self._extras.append(_Extra(channel, _ns(t), message, ROBUSTNESS))
        self.metadata.update(
            requirement=evaluation.formula,
            robustness=evaluation.robustness,
            worst_time=evaluation.worst_time,
            worst_values=dict(evaluation.values),
            signals=list(evaluation.values),
            predicate=evaluation.predicate,
            first_violation=evaluation.first_violation,
        )

    # -- saving ---------------------------------------------------------------------------

    def save(self, path: str | Path, **metadata: object) -> Path:
        """Write the trace to ``path`` (MCAP); ``metadata`` adds to the record."""
        path = Path(path)
        self.channels = write_mcap(path, self._rows(), {**self.metadata, **metadata})
        return path

    def save_tlog(self, path: str | Path) -> Path | None:
        """Write the MAVLink frames of the ``tlog`` topics as a ``.tlog`` (None: there are none)."""
        topics = set(self.options.tlog)
        frames: list[tuple[int, bytes]] = []
        for d in self.deliveries:
            if d.topic in topics:
                message = self._builtins(d)
                data = message.get("data") if isinstance(message, dict) else None
                if isinstance(data, bytes):
                    frames.append((d.time_ns, data))
        if not frames:
            return None
        return write_tlog(Path(path), frames)

    def save_layout(self, path: str | Path) -> Path:
        """Write a Foxglove layout, for the trace this recorder last saved, at ``path``."""
        from ._layout import layout

        path = Path(path)
        document = layout(self.channels, self.options.plots, self.metadata)
        try:
            with replacing(path) as temporary:
                temporary.write_text(json.dumps(document, indent=2) + "\n")
        except OSError as exc:
            raise TraceError(f"could not write the layout {str(path)!r}: {exc}") from exc
        return path

    def _rows(self) -> Iterator[Row]:
        # (time, order, channel, schema, payload): sorted so readers stream in time order.
        rows: list[tuple[int, int, str, Schema, bytes]] = []
        by_topic: dict[str, list[Converter]] = {}
        for converter in self.converters:
            for topic in converter.topics:
                by_topic.setdefault(topic, []).append(converter)
        replaced = set(self.options.replaced)
        topic_schema: dict[str, Schema] = {}
        order = 0
        for d in self.deliveries:
            converters = by_topic.get(d.topic, ())
            if d.topic not in replaced:
                payload, schema = self._payload(d, topic_schema)
                rows.append((d.time_ns, order, d.topic, schema, payload))
                order += 1
            if converters:
                message = self._builtins(d)
                for converter in converters:
                    for c in converter(d.topic, d.time_ns, message):
                        rows.append((d.time_ns, order, c.channel, c.schema, _encode(c.message)))
                        order += 1
        for e in self._extras:
            payload = _encode(e.message)
            schema = e.schema or _schema_of(e.message, payload)
            if schema is WRAPPED:
                payload = b'{"value":' + payload + b"}"
            rows.append((e.time_ns, order, e.channel, schema, payload))
            order += 1
        rows.sort(key=lambda r: (r[0], r[1]))
        return ((t, topic, schema, payload) for t, _, topic, schema, payload in rows)

    def _typed(self, d: Delivery) -> Any:
        """The delivery's message: the publisher's object, or decoded (typed if known)."""
        if d.obj is not None:
            return d.obj
        tp = self.types.get(d.topic)
        try:
            return (
                msgspec.msgpack.decode(d.data, type=tp)
                if tp is not None
                else (msgspec.msgpack.decode(d.data))
            )
        except msgspec.DecodeError as exc:  # ValidationError included
            raise TraceError(
                f"message on topic {d.topic!r} at t={d.time_ns / 1e9:g} s could not be decoded: "
                f"{exc}"
            ) from exc

    def _builtins(self, d: Delivery) -> Any:
        """The message as JSON-like builtins, objects as dicts, bytes kept (for converters)."""
        return to_builtins(self._typed(d))

    def _payload(self, d: Delivery, topic_schema: dict[str, Schema]) -> tuple[bytes, Schema]:
        message = self._typed(d)
        tp = type(message)
        if _has_schema(tp) and not is_array_like(tp):
            payload = _encode(message)  # one pass: the common case of a Struct message
        else:
            payload = _encode(to_builtins(message))
        schema = topic_schema.get(d.topic)
        if schema is None:
            schema = topic_schema[d.topic] = _schema_of(message, payload)
        if schema is WRAPPED:
            payload = b'{"value":' + payload + b"}"
        return payload, schema


_encoder = msgspec.json.Encoder()
_KEEP = (bytes, bytearray, memoryview)


def to_builtins(message: Any) -> Any:
    """``message`` as JSON-like builtins (objects as dicts), bytes kept as they are."""
    if is_array_like(type(message)):
        return {
            f: msgspec.to_builtins(getattr(message, f), builtin_types=_KEEP)
            for f in message.__struct_fields__
        }
    return msgspec.to_builtins(message, builtin_types=_KEEP)


def _encode(message: object) -> bytes:
    try:
        return _encoder.encode(message)
    except (TypeError, msgspec.EncodeError) as exc:
        raise TraceError(f"a message could not be encoded as JSON: {message!r:.200}") from exc


def _schema_of(message: object, payload: bytes) -> Schema:
    if not payload.startswith(b"{"):
        return WRAPPED  # Foxglove's json encoding wants objects: wrap scalars, lists
    tp: Any = type(message)
    if message is not None and _has_schema(tp):
        return schema_for(tp)
    return ANY_OBJECT


def _has_schema(tp: type) -> bool:
    return issubclass(tp, msgspec.Struct) or dataclasses.is_dataclass(tp)


def _json_float(value: float) -> float | None:
    return value if math.isfinite(value) else None  # JSON has no NaN


def _ns(time: float) -> int:
    if not math.isfinite(time) or time < 0:
        raise ConfigurationError("time", time, "a finite simulated time >= 0 s")
    return round(time * 1e9)
