"""Record every topic of a simulation into an MCAP file that Foxglove opens.

::

    from multicosim.trace import Recorder, read_trace

    with Recorder().attach(simulation) as recorder:
        trajectory = simulation.controller.send(mission)
    recorder.add_trajectory(trajectory)
    recorder.save("run.mcap", seed=0, fidelity="low")
    trace = read_trace("run.mcap")

Recording is cheap by design: the scheduler's tap only appends each routed message to a list;
conversion to JSON and writing happen in :meth:`Recorder.save`, typically only for a failing
test. Channels use JSON schemas (``jsonschema`` + ``json``), generated from the message type
when it is known: the in-process publisher's object, or the ``types`` mapping (topic -> type)
for messages that crossed a process boundary; other topics get a permissive schema.
Converters (:func:`location_fix`, :func:`pose_in_frame`) add Foxglove well-known channels
(``foxglove.LocationFix`` for the map panel, ``foxglove.PoseInFrame`` for the 3D panel).

Log times are simulated time (nanoseconds from the start of the simulation), so the same seed
gives a byte-identical trace.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.metadata
import json
import math
import platform
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import msgspec

from ._deps import require
from ._errors import ConfigurationError, TraceError

if TYPE_CHECKING:
    from ._clock import Delivery, Scheduler
    from .requirements import Evaluation, Requirement, Signals

__all__ = [
    "LOCATION_FIX",
    "METADATA_NAME",
    "POSE_IN_FRAME",
    "ChannelInfo",
    "Converted",
    "Converter",
    "Recorder",
    "Schema",
    "TestTrace",
    "TraceData",
    "TraceMessage",
    "TraceOptions",
    "activate",
    "active",
    "falsifying_example",
    "location_fix",
    "package_versions",
    "plot_command",
    "plot_trace",
    "pose_in_frame",
    "read_trace",
    "trace_options",
]

METADATA_NAME = "multicosim"
TRAJECTORY_CHANNEL = "mcs/trajectory"
PLAN_CHANNEL = "mcs/plan"
ROBUSTNESS_CHANNEL = "mcs/robustness"
LOCATION_CHANNEL = "mcs/location"
POSE_CHANNEL = "mcs/pose"
# Distributions whose versions go into a trace's metadata (what made the run what it is).
VERSIONED = (
    "multicosim",
    "msgspec",
    "numpy",
    "pyzmq",
    "mujoco",
    "mcap",
    "rtamt",
    "hypothesis",
    "psy-taliro",
    "docker",
    "pymavlink",
)


# -- schemas --------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Schema:
    """A channel's JSON schema and its name (Foxglove recognises well-known names)."""

    name: str
    schema: Mapping[str, Any]


def _time_schema() -> dict[str, Any]:
    return {
        "type": "object",
        "title": "time",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
        },
    }


def _vector3() -> dict[str, Any]:
    return {
        "type": "object",
        "properties": {k: {"type": "number"} for k in ("x", "y", "z")},
    }


LOCATION_FIX = Schema(
    "foxglove.LocationFix",
    {
        "title": "foxglove.LocationFix",
        "description": "A navigation satellite fix for any Global Navigation Satellite System",
        "type": "object",
        "properties": {
            "timestamp": _time_schema(),
            "frame_id": {"type": "string"},
            "latitude": {"type": "number", "description": "Latitude in degrees"},
            "longitude": {"type": "number", "description": "Longitude in degrees"},
            "altitude": {"type": "number", "description": "Altitude in meters"},
            "position_covariance": {
                "type": "array",
                "items": {"type": "number"},
                "minItems": 9,
                "maxItems": 9,
            },
            "position_covariance_type": {
                "title": "foxglove.PositionCovarianceType",
                "oneOf": [
                    {"title": "UNKNOWN", "const": 0},
                    {"title": "APPROXIMATED", "const": 1},
                    {"title": "DIAGONAL_KNOWN", "const": 2},
                    {"title": "KNOWN", "const": 3},
                ],
            },
        },
    },
)

POSE_IN_FRAME = Schema(
    "foxglove.PoseInFrame",
    {
        "title": "foxglove.PoseInFrame",
        "description": "A timestamped pose for an object or reference frame in 3D space",
        "type": "object",
        "properties": {
            "timestamp": _time_schema(),
            "frame_id": {"type": "string"},
            "pose": {
                "type": "object",
                "properties": {
                    "position": _vector3(),
                    "orientation": {
                        "type": "object",
                        "properties": {k: {"type": "number"} for k in ("x", "y", "z", "w")},
                    },
                },
            },
        },
    },
)

_ANY_OBJECT: Mapping[str, Any] = {"type": "object"}
_WRAPPED: Mapping[str, Any] = {"type": "object", "properties": {"value": {}}}


def schema_for(tp: Any) -> Schema:
    """The JSON schema of message type ``tp``, rooted at the type itself (not a ``$ref``)."""
    generated = msgspec.json.schema(tp)
    defs = dict(generated.get("$defs", {}))
    ref = generated.get("$ref", "")
    name = ref.rsplit("/", 1)[-1] if ref else getattr(tp, "__name__", str(tp))
    root = dict(defs.pop(name, generated))
    root.pop("$ref", None)
    if defs:
        root["$defs"] = defs  # nested types keep resolving as "#/$defs/..."
    return Schema(_qualified(tp), root)


def _qualified(tp: Any) -> str:
    module = getattr(tp, "__module__", "")
    qualname = getattr(tp, "__qualname__", None) or getattr(tp, "__name__", str(tp))
    return f"{module}.{qualname}" if module else str(qualname)


def _stamp(time_ns: int) -> dict[str, int]:
    return {"sec": time_ns // 1_000_000_000, "nsec": time_ns % 1_000_000_000}


# -- converters -----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Converted:
    """One message a converter derives from a recorded one."""

    channel: str
    schema: Schema
    message: Mapping[str, Any]


class Converter(Protocol):
    """Derives messages (e.g. Foxglove well-known ones) from the messages of ``topics``.

    It is called at save time, in time order, with the message as JSON-like builtins (what
    the topic's channel shows), so it works the same for in-process and process publishers.
    """

    @property
    def topics(self) -> tuple[str, ...]:
        """The recorded topics it converts."""
        ...

    def __call__(self, topic: str, time_ns: int, message: Any) -> Iterable[Converted]:
        """The derived messages for one recorded message."""
        ...


@dataclasses.dataclass(frozen=True)
class _FieldConverter:
    topics: tuple[str, ...]
    channel: str
    build: Callable[[Any, int], Mapping[str, Any] | None]
    schema: Schema

    def __call__(self, topic: str, time_ns: int, message: Any) -> Iterable[Converted]:
        built = self.build(message, time_ns)
        return () if built is None else (Converted(self.channel, self.schema, built),)


def location_fix(
    topic: str,
    position: Callable[[Any], tuple[float, float, float] | None],
    *,
    channel: str = LOCATION_CHANNEL,
    frame_id: str = "base_link",
) -> Converter:
    """A ``foxglove.LocationFix`` channel from ``topic``.

    ``position(message)`` returns (latitude, longitude, altitude) in degrees and metres, or
    None to skip the message, e.g. ``lambda m: (m["latitude"], m["longitude"], m["altitude"])``.
    """

    def build(message: Any, time_ns: int) -> Mapping[str, Any] | None:
        fix = position(message)
        if fix is None:
            return None
        lat, lon, alt = (float(v) for v in fix)
        return {
            "timestamp": _stamp(time_ns),
            "frame_id": frame_id,
            "latitude": lat,
            "longitude": lon,
            "altitude": alt,
            "position_covariance": [0.0] * 9,
            "position_covariance_type": 0,
        }

    return _FieldConverter((topic,), channel, build, LOCATION_FIX)


def pose_in_frame(
    topic: str,
    pose: Callable[[Any], tuple[Sequence[float], Sequence[float]] | None],
    *,
    channel: str = POSE_CHANNEL,
    frame_id: str = "map",
) -> Converter:
    """A ``foxglove.PoseInFrame`` channel from ``topic``.

    ``pose(message)`` returns ((x, y, z), (w, x, y, z)): position in metres in ``frame_id``
    and orientation as a unit quaternion (scalar first, as MuJoCo writes it), or None.
    """

    def build(message: Any, time_ns: int) -> Mapping[str, Any] | None:
        found = pose(message)
        if found is None:
            return None
        (px, py, pz), (qw, qx, qy, qz) = found
        return {
            "timestamp": _stamp(time_ns),
            "frame_id": frame_id,
            "pose": {
                "position": {"x": float(px), "y": float(py), "z": float(pz)},
                "orientation": {"x": float(qx), "y": float(qy), "z": float(qz), "w": float(qw)},
            },
        }

    return _FieldConverter((topic,), channel, build, POSE_IN_FRAME)


# -- the recorder ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class TraceOptions:
    """What a scenario tells the recorder: topic types, converters, the planned path.

    A simulation offers them with a ``trace_options()`` method; recorders attached to it use
    them (their own ``types`` and ``converters`` take precedence).
    """

    types: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    converters: Sequence[Converter] = ()
    plan: Sequence[Sequence[float]] = ()


def trace_options(simulation: object) -> TraceOptions:
    """The scenario's trace options of ``simulation`` (empty if it offers none)."""
    method = getattr(simulation, "trace_options", None)
    options = method() if callable(method) else None
    if options is None:
        return TraceOptions()
    if not isinstance(options, TraceOptions):
        raise ConfigurationError(
            "trace_options()", options, "a multicosim.trace.TraceOptions (or None)"
        )
    return options


def find_scheduler(simulation: object) -> Scheduler:
    """The scheduler of ``simulation`` (a local or container simulation, or a wrapper of one)."""
    from ._clock import Scheduler

    seen: set[int] = set()
    node: object = simulation
    while id(node) not in seen:
        seen.add(id(node))
        if isinstance(node, Scheduler):
            return node
        environment = getattr(node, "environment", None)
        scheduler = getattr(environment, "scheduler", None) or getattr(node, "scheduler", None)
        if isinstance(scheduler, Scheduler):
            return scheduler
        inner = getattr(node, "simulation", None)  # scenario wrappers (RoverSimulation, ...)
        if inner is None:
            break
        node = inner
    raise ConfigurationError(
        "simulation",
        simulation,
        "a simulation with a simulated clock (ProcessSimulation, ContainerSimulation, "
        "or an object whose .simulation is one)",
    )


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
    ``metadata`` goes into the trace's metadata record.
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
        self.metadata: dict[str, object] = dict(metadata or {})
        self.deliveries: list[Delivery] = []
        self._extras: list[_Extra] = []
        self._scheduler: Scheduler | None = None
        self._tap: Callable[[Delivery], None] | None = None

    # -- recording (hot path: one list append per routed message) ---------------------------

    def attach(self, simulation: object) -> Recorder:
        """Record every message routed in ``simulation`` from now on; returns self."""
        if self._scheduler is not None:
            raise TraceError("this recorder is already attached to a simulation")
        scheduler = find_scheduler(simulation)
        options = trace_options(simulation)
        self.types = {**options.types, **self.types}
        self.converters = [*options.converters, *self.converters]
        if options.plan and not any(e.channel == PLAN_CHANNEL for e in self._extras):
            self.add_plan(options.plan)
        # The bound method itself is the tap: no Python frame of ours runs per message.
        self._tap = self.deliveries.append
        scheduler.taps.append(self._tap)
        self._scheduler = scheduler
        return self

    def detach(self) -> None:
        """Stop recording (the recorded messages stay); idempotent."""
        if self._scheduler is not None and self._tap is not None:
            with contextlib.suppress(ValueError):
                self._scheduler.taps.remove(self._tap)
        self._scheduler = None
        self._tap = None

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
        from .requirements import signals_of

        self._add_signals(signals_of(trajectory, times=times), channel)

    def _add_signals(self, signals: Signals, channel: str) -> None:
        self._extras = [e for e in self._extras if e.channel != channel]
        names = list(signals.columns)
        rows = zip(*(signals.columns[n].tolist() for n in names), strict=True)
        for t, row in zip(signals.times.tolist(), rows, strict=True):
            message = {"time": t, **{n: _json_float(v) for n, v in zip(names, row, strict=True)}}
            self._extras.append(_Extra(channel, _ns(t), message, _signals_schema(names)))

    def add_plan(
        self, points: Sequence[Sequence[float]], *, time: float = 0.0, channel: str = PLAN_CHANNEL
    ) -> None:
        """Record the planned path: points (x, y[, z]) in the local frame, in metres."""
        path = [
            {"x": float(p[0]), "y": float(p[1]), "z": float(p[2]) if len(p) > 2 else 0.0}
            for p in points
        ]
        self._extras = [e for e in self._extras if e.channel != channel]
        schema = Schema(
            "multicosim.Plan",
            {"type": "object", "properties": {"points": {"type": "array", "items": _vector3()}}},
        )
        self._extras.append(_Extra(channel, _ns(time), {"points": path}, schema))

    def add_evaluation(
        self,
        evaluation: Evaluation,
        series: Sequence[tuple[float, float]] = (),
        *,
        channel: str = ROBUSTNESS_CHANNEL,
    ) -> None:
        """Record a requirement's robustness (over time when ``series`` is given)."""
        self._extras = [e for e in self._extras if e.channel != channel]
        schema = Schema(
            "multicosim.Robustness",
            {
                "type": "object",
                "properties": {
                    "formula": {"type": "string"},
                    "robustness": {"type": "number"},
                    "margin": {"type": "number"},
                    "predicate": {"type": "string"},
                },
            },
        )
        points = list(series) or list(evaluation.series)
        points = points or [(evaluation.worst_time, evaluation.robustness)]
        for t, margin in points:
            message = {
                "formula": evaluation.formula,
                "robustness": _json_float(evaluation.robustness),
                "margin": _json_float(margin),
                "predicate": evaluation.predicate,
            }
            self._extras.append(_Extra(channel, _ns(t), message, schema))
        self.metadata.update(
            requirement=evaluation.formula,
            robustness=evaluation.robustness,
            worst_time=evaluation.worst_time,
            worst_values=dict(evaluation.values),
        )

    # -- saving ---------------------------------------------------------------------------

    def save(self, path: str | Path, **metadata: object) -> Path:
        """Write the trace to ``path`` (MCAP, zstd chunks); ``metadata`` adds to the record."""
        mcap_writer = require("mcap.writer", "trace")
        path = Path(path)
        record = {**self.metadata, **metadata}
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with open(path, "wb") as stream:
                writer = mcap_writer.Writer(stream)
                writer.start(profile="", library=f"multicosim {_version('multicosim')}")
                self._write(writer)
                writer.add_metadata(METADATA_NAME, _metadata_record(record))
                writer.finish()
        except OSError as exc:
            raise TraceError(f"could not write the trace {str(path)!r}: {exc}") from exc
        return path

    def _write(self, writer: Any) -> None:
        channels: dict[str, int] = {}
        schemas: dict[tuple[str, str], int] = {}

        def channel_id(topic: str, schema: Schema) -> int:
            cid = channels.get(topic)
            if cid is None:
                text = json.dumps(schema.schema, sort_keys=True)
                sid = schemas.get((schema.name, text))
                if sid is None:
                    sid = writer.register_schema(schema.name, "jsonschema", text.encode())
                    schemas[(schema.name, text)] = sid
                cid = writer.register_channel(topic, "json", sid)
                channels[topic] = cid
            return cid

        # (time, order, channel, schema, payload): sorted so readers stream in time order.
        rows: list[tuple[int, int, str, Schema, bytes]] = []
        by_topic = self._converters_by_topic()
        topic_schema: dict[str, Schema] = {}
        order = 0
        for d in self.deliveries:
            message, payload = self._payload(d)
            schema = topic_schema.get(d.topic)
            if schema is None:
                schema = topic_schema[d.topic] = self._schema(d, payload)
            if schema is _WRAPPED_SCHEMA:
                payload = b'{"value":' + payload + b"}"
            rows.append((d.time_ns, order, d.topic, schema, payload))
            order += 1
            for converter in by_topic.get(d.topic, ()):
                builtins = message if message is not _UNDECODED else msgspec.json.decode(payload)
                for c in converter(d.topic, d.time_ns, builtins):
                    rows.append((d.time_ns, order, c.channel, c.schema, _encode(c.message)))
                    order += 1
        for e in self._extras:
            payload = _encode(e.message)
            schema = e.schema or _schema_of(e.message, payload)
            if schema is _WRAPPED_SCHEMA:
                payload = b'{"value":' + payload + b"}"
            rows.append((e.time_ns, order, e.channel, schema, payload))
            order += 1
        rows.sort(key=lambda r: (r[0], r[1]))
        sequence: dict[str, int] = {}
        for time_ns, _, topic, schema, payload in rows:
            cid = channel_id(topic, schema)
            seq = sequence[topic] = sequence.get(topic, 0) + 1
            writer.add_message(
                cid, log_time=time_ns, data=payload, publish_time=time_ns, sequence=seq
            )

    def _converters_by_topic(self) -> dict[str, list[Converter]]:
        out: dict[str, list[Converter]] = {}
        for converter in self.converters:
            for topic in converter.topics:
                out.setdefault(topic, []).append(converter)
        return out

    def _payload(self, d: Delivery) -> tuple[Any, bytes]:
        """A delivery's JSON payload and, when cheap, its builtins form (for converters)."""
        if d.obj is not None:
            return _UNDECODED, _encode(d.obj)
        tp = self.types.get(d.topic)
        try:
            if tp is not None:
                obj = msgspec.msgpack.decode(d.data, type=tp)
                return _UNDECODED, _encode(obj)
            message = msgspec.msgpack.decode(d.data)
        except msgspec.DecodeError as exc:  # ValidationError included
            raise TraceError(
                f"message on topic {d.topic!r} at t={d.time_ns / 1e9:g} s could not be decoded: "
                f"{exc}"
            ) from exc
        return message, _encode(message)

    def _schema(self, d: Delivery, payload: bytes) -> Schema:
        tp = self.types.get(d.topic)
        if tp is None and d.obj is not None and _has_schema(type(d.obj)):
            tp = type(d.obj)
        if tp is not None:
            if not payload.startswith(b"{"):
                return _WRAPPED_SCHEMA
            return schema_for(tp)
        return _schema_of(None, payload)


_UNDECODED: Any = object()
_WRAPPED_SCHEMA = Schema("multicosim.Value", _WRAPPED)
_encoder = msgspec.json.Encoder()


def _encode(message: object) -> bytes:
    try:
        return _encoder.encode(message)
    except (TypeError, msgspec.EncodeError) as exc:
        raise TraceError(f"a message could not be encoded as JSON: {message!r:.200}") from exc


def _schema_of(message: object, payload: bytes) -> Schema:
    if not payload.startswith(b"{"):
        return _WRAPPED_SCHEMA  # Foxglove's json encoding wants objects: wrap scalars, lists
    if message is not None and _has_schema(type(message)):
        return schema_for(type(message))
    return Schema("multicosim.Any", _ANY_OBJECT)


def _has_schema(tp: type) -> bool:
    return issubclass(tp, msgspec.Struct) or dataclasses.is_dataclass(tp)


def _signals_schema(names: Sequence[str]) -> Schema:
    props = {"time": {"type": "number"}, **{n: {"type": ["number", "null"]} for n in names}}
    return Schema("multicosim.Sample", {"type": "object", "properties": props})


def _json_float(value: float) -> float | None:
    return value if math.isfinite(value) else None  # JSON has no NaN


def _ns(time: float) -> int:
    if not math.isfinite(time) or time < 0:
        raise ConfigurationError("time", time, "a finite simulated time >= 0 s")
    return round(time * 1e9)


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def package_versions() -> dict[str, str]:
    """Python and the versions of the packages that shape a run."""
    versions = {"python": platform.python_version()}
    versions.update({name: _version(name) for name in VERSIONED})
    return versions


def _metadata_record(record: Mapping[str, object]) -> dict[str, str]:
    """MCAP metadata holds strings: keep strings as they are, encode the rest as JSON."""
    out = {"versions": json.dumps(package_versions(), sort_keys=True)}
    for key, value in record.items():
        if value is None:
            continue
        if isinstance(value, str):
            out[key] = value
        else:
            out[key] = msgspec.json.encode(value, order="sorted").decode()
    return dict(sorted(out.items()))


# -- reading --------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class ChannelInfo:
    """A channel of a trace: topic, schema name and schema, encoding, message count."""

    topic: str
    schema_name: str
    schema: Mapping[str, Any]
    message_encoding: str
    count: int


@dataclasses.dataclass(frozen=True)
class TraceMessage:
    """One message of a trace, decoded from JSON."""

    topic: str
    log_time: int
    data: Any

    @property
    def time(self) -> float:
        """Simulated time in seconds."""
        return self.log_time / 1e9


@dataclasses.dataclass(frozen=True)
class TraceData:
    """A trace read back: channels by topic, messages in time order, metadata records."""

    channels: Mapping[str, ChannelInfo]
    messages: Sequence[TraceMessage]
    metadata: Mapping[str, Mapping[str, str]]

    def topic(self, name: str) -> list[TraceMessage]:
        """The messages of topic ``name`` in time order."""
        return [m for m in self.messages if m.topic == name]

    @property
    def info(self) -> Mapping[str, str]:
        """The multicosim metadata record (empty if absent)."""
        return self.metadata.get(METADATA_NAME, {})


def read_trace(path: str | Path) -> TraceData:
    """Read a trace with the mcap reader; raise TraceError if it is not a readable MCAP file."""
    mcap_reader = require("mcap.reader", "trace")
    channels: dict[str, ChannelInfo] = {}
    counts: dict[str, int] = {}
    messages: list[TraceMessage] = []
    metadata: dict[str, dict[str, str]] = {}
    try:
        stream = open(path, "rb")  # noqa: SIM115 - closed below, apart from parse errors
    except OSError as exc:
        raise TraceError(f"could not read the trace {str(path)!r}: {exc}") from exc
    try:
        with stream:
            reader = mcap_reader.make_reader(stream)
            for schema, channel, message in reader.iter_messages(log_time_order=True):
                if channel.topic not in channels:
                    channels[channel.topic] = ChannelInfo(
                        channel.topic,
                        schema.name if schema is not None else "",
                        json.loads(schema.data) if schema is not None and schema.data else {},
                        channel.message_encoding,
                        0,
                    )
                counts[channel.topic] = counts.get(channel.topic, 0) + 1
                data = (
                    json.loads(message.data)
                    if channel.message_encoding == "json"
                    else bytes(message.data)
                )
                messages.append(TraceMessage(channel.topic, message.log_time, data))
            for record in reader.iter_metadata():
                metadata[record.name] = dict(record.metadata)
    except Exception as exc:  # the mcap reader raises assorted errors on corrupt input
        raise TraceError(f"{str(path)!r} is not a readable MCAP trace: {exc}") from exc
    channels = {t: dataclasses.replace(c, count=counts[t]) for t, c in channels.items()}
    return TraceData(channels, messages, metadata)


# -- per-test traces (used by the pytest plugin) --------------------------------------------


class TestTrace:
    """The traces of one test: a recorder per simulation started in it, plus notes.

    The pytest plugin activates one around each test call (:func:`activate`); simulations
    started through ``mcs_simulations`` or a fresh-simulation factory are attached to it, and
    requirement evaluations are noted in it. With ``record=False`` (``--mcs-keep-traces=none``)
    it only carries the test's metadata (fidelity, seed) for fresh simulations.
    :meth:`begin_example` forgets what an earlier
    Hypothesis example recorded, so what is saved is the last (for a failing test: the final,
    minimal) example.
    """

    __test__ = False  # not a pytest test class, despite the name

    def __init__(
        self,
        *,
        metadata: Mapping[str, object] | None = None,
        types: Mapping[str, Any] | None = None,
        converters: Sequence[Converter] = (),
        record: bool = True,
    ) -> None:
        self.metadata: dict[str, object] = dict(metadata or {})
        self.record = record
        self.types = dict(types or {})
        self.converters = list(converters)
        self.recorders: list[Recorder] = []
        self.example = 0
        self._evaluation: tuple[Evaluation, Signals] | None = None
        self._lock = threading.Lock()

    def attach(
        self,
        simulation: object,
        *,
        types: Mapping[str, Any] | None = None,
        converters: Sequence[Converter] = (),
    ) -> Recorder | None:
        """Record ``simulation`` (unless ``record`` is off: then None).

        Scenario ``types``/``converters`` add to the test's own.
        """
        if not self.record:
            return None
        recorder = Recorder(
            types={**self.types, **(types or {})},
            converters=[*self.converters, *converters],
        )
        recorder.attach(simulation)
        with self._lock:
            self.recorders.append(recorder)
        return recorder

    def begin_example(self) -> None:
        """A new Hypothesis example starts: drop the recordings of the previous one."""
        with self._lock:
            for recorder in self.recorders:
                recorder.detach()
            self.recorders = []
            self._evaluation = None
            self.example += 1

    def note_evaluation(
        self, requirement: Requirement, signals: Signals, evaluation: Evaluation
    ) -> None:
        """Keep the latest requirement evaluation (its trajectory and robustness go in)."""
        if self.record:
            self._evaluation = (evaluation, signals)

    def save(self, directory: str | Path, *, plot: bool = True, **metadata: object) -> list[Path]:
        """Write one MCAP file per recorded simulation (and a PNG plot beside each).

        Returns the written paths (traces, then plots). Nothing is written when nothing was
        recorded. A failing plot (matplotlib missing, say) does not prevent the trace.
        """
        directory = Path(directory)
        recorders = list(self.recorders)
        if not recorders and self._evaluation is not None:
            recorders = [Recorder(types=self.types, converters=self.converters)]
        written: list[Path] = []
        plots: list[Path] = []
        for index, recorder in enumerate(recorders):
            recorder.metadata.update(self.metadata)
            if self._evaluation is not None and index == len(recorders) - 1:
                evaluation, signals = self._evaluation
                recorder._add_signals(signals, TRAJECTORY_CHANNEL)
                recorder.add_evaluation(evaluation)
            name = "trace.mcap" if len(recorders) == 1 else f"trace-{index}.mcap"
            path = recorder.save(directory / name, **metadata)
            written.append(path)
            if plot:
                with contextlib.suppress(Exception):
                    plots.append(plot_trace(path, path.with_suffix(".png")))
        return written + plots


_EXAMPLE_HEADS = ("Falsifying example:", "Failing test case:")  # Hypothesis's wordings


def falsifying_example(failure: BaseException | str) -> str | None:
    """The failing example Hypothesis reported, from the exception's notes or a report text.

    Returns the call Hypothesis prints (``Failing test case: test_x(speed=1.5, ...)``), or
    None for a failure that did not come from Hypothesis.
    """
    if isinstance(failure, BaseException):
        for note in getattr(failure, "__notes__", ()):
            if isinstance(note, str) and note.startswith(_EXAMPLE_HEADS):
                return note.strip()
        return None
    # A report text: pytest prefixes exception lines with "E   ".
    lines = [line[4:] if line.startswith("E   ") else line for line in failure.splitlines()]
    for i, line in enumerate(lines):
        if not line.startswith(_EXAMPLE_HEADS):
            continue
        block = [line]
        if line.rstrip().endswith("("):  # the call spans lines up to its closing parenthesis
            for following in lines[i + 1 :]:
                block.append(following)
                if following.startswith(")"):
                    break
        return "\n".join(block).strip()
    return None


_active: TestTrace | None = None


def active() -> TestTrace | None:
    """The trace of the test running now, if the plugin activated one."""
    return _active


@contextlib.contextmanager
def activate(test_trace: TestTrace) -> Iterator[TestTrace]:
    """Make ``test_trace`` the active one for the duration of the block (one test call)."""
    global _active
    previous, _active = _active, test_trace
    try:
        yield test_trace
    finally:
        _active = previous
        for recorder in test_trace.recorders:
            recorder.detach()


def _note_evaluation(requirement: Requirement, signals: Signals, evaluation: Evaluation) -> None:
    """Called by Requirement.evaluate: note it in the active test's trace."""
    if _active is not None:
        _active.note_evaluation(requirement, signals, evaluation)


# -- plots ----------------------------------------------------------------------------------


def _columns(messages: Sequence[TraceMessage], *names: str) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {"time": []}
    for n in names:
        out[n] = []
    for m in messages:
        if not isinstance(m.data, dict) or not all(
            isinstance(m.data.get(n), int | float) for n in names
        ):
            continue
        out["time"].append(m.time)
        for n in names:
            out[n].append(float(m.data[n]))
    return out


def _first(keys: Iterable[str], candidates: Sequence[str]) -> str | None:
    present = set(keys)
    return next((c for c in candidates if c in present), None)


def plot_trace(trace: str | Path, output: str | Path) -> Path:
    """Plot a trace: planned vs flown path, altitude and robustness over time (PNG)."""
    require("matplotlib", "plot")
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    data = read_trace(trace)
    output = Path(output)
    trajectory = data.topic(TRAJECTORY_CHANNEL)
    keys: set[str] = set()
    for m in trajectory[:1]:
        keys = set(m.data) if isinstance(m.data, dict) else set()
    fixes = data.topic(LOCATION_CHANNEL)
    plans = data.topic(PLAN_CHANNEL)
    robustness = data.topic(ROBUSTNESS_CHANNEL)

    fig, (ax_path, ax_alt, ax_rob) = plt.subplots(3, 1, figsize=(8, 11))
    title = data.info.get("test") or Path(trace).name
    fig.suptitle(str(title), fontsize=10)

    # Path: the trajectory's x/y, else the location fixes projected around the first one.
    if {"x", "y"} <= keys:
        cols = _columns(trajectory, "x", "y")
        ax_path.plot(cols["x"], cols["y"], label="flown", color="tab:blue")
        ax_path.set_xlabel("x (m, east)")
        ax_path.set_ylabel("y (m, north)")
    elif fixes:
        cols = _columns(fixes, "latitude", "longitude")
        lat0, lon0 = cols["latitude"][0], cols["longitude"][0]
        k = 111_320.0
        east = [(lon - lon0) * k * math.cos(math.radians(lat0)) for lon in cols["longitude"]]
        north = [(lat - lat0) * k for lat in cols["latitude"]]
        ax_path.plot(east, north, label="flown (GPS)", color="tab:blue")
        ax_path.set_xlabel("east (m)")
        ax_path.set_ylabel("north (m)")
    elif "x" in keys:
        cols = _columns(trajectory, "x")
        ax_path.plot(cols["time"], cols["x"], label="flown x", color="tab:blue")
        ax_path.set_xlabel("time (s)")
        ax_path.set_ylabel("x (m)")
    for m in plans[-1:]:
        points = m.data.get("points", []) if isinstance(m.data, dict) else []
        if points and ({"x", "y"} <= keys or fixes):
            ax_path.plot(
                [p["x"] for p in points],
                [p["y"] for p in points],
                "--",
                label="planned",
                color="tab:orange",
            )
    ax_path.set_title("path: planned vs flown")
    if ax_path.has_data():
        ax_path.legend(loc="best")
        if {"x", "y"} <= keys or fixes:
            ax_path.set_aspect("equal", adjustable="datalim")

    # Altitude: a trajectory column, else the location fixes, else the other signals.
    column = _first(keys, ("alt", "altitude", "z"))
    ax_alt.set_title("altitude")
    if column is not None:
        cols = _columns(trajectory, column)
        ax_alt.plot(cols["time"], cols[column], color="tab:green", label=column)
        ax_alt.set_ylabel("m")
    elif fixes:
        cols = _columns(fixes, "altitude")
        ax_alt.plot(cols["time"], cols["altitude"], color="tab:green", label="GPS altitude")
        ax_alt.set_ylabel("m")
    else:
        ax_alt.set_title("signals (no altitude recorded)")
        for name in sorted(keys - {"time", "x", "y"}):
            cols = _columns(trajectory, name)
            ax_alt.plot(cols["time"], cols[name], label=name)
    if ax_alt.has_data():
        ax_alt.legend(loc="best")
    ax_alt.set_xlabel("time (s)")

    if robustness:
        cols = _columns(robustness, "margin", "robustness")
        first = robustness[0].data
        label = f"margin of {first.get('predicate')}"
        ax_rob.plot(
            cols["time"], cols["margin"], color="tab:purple", label=label, drawstyle="steps-post"
        )
        ax_rob.axhline(0.0, color="black", linewidth=0.8)
        rho = first.get("robustness")
        if isinstance(rho, int | float):
            ax_rob.axhline(rho, color="tab:red", linestyle="--", linewidth=0.8, label="robustness")
        worst = data.info.get("worst_time")
        if worst is not None:
            ax_rob.axvline(float(worst), color="tab:red", linestyle=":", label="worst time")
        rho_text = f"{rho:.4g}" if isinstance(rho, int | float) else "n/a"
        ax_rob.set_title(f"robustness of {first.get('formula')}: {rho_text}")
        ax_rob.legend(loc="best")
    else:
        ax_rob.set_title("robustness (no requirement evaluated)")
    ax_rob.set_xlabel("time (s)")
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=80)
    plt.close(fig)
    return output


def plot_command(trace: str, output: str | None = None) -> int:
    """``multicosim plot TRACE.mcap -o OUT.png``: write the plot, print its path."""
    target = Path(output) if output else Path(trace).with_suffix(".png")
    try:
        written = plot_trace(trace, target)
    except (TraceError, ConfigurationError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(written)
    return 0
