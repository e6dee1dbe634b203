"""Converters: channels derived from recorded messages at save time, and TraceOptions.

A scenario tells recorders what its topics mean with ``trace_options()``: message types,
converters that derive Foxglove well-known channels (``foxglove.LocationFix`` for the Map
panel, ``foxglove.PoseInFrame`` and ``foxglove.SceneUpdate`` for the 3D panel, ...) and local
paths for the plot, topics that only make sense decoded, MAVLink links for a ``.tlog`` and the
plots a layout shows.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Protocol

from ..core.errors import ConfigurationError
from ._schemas import LOCATION_FIX, PATH_POINT, POSE_IN_FRAME, Schema, stamp

__all__ = [
    "LOCATION_CHANNEL",
    "PATH_CHANNEL",
    "POSE_CHANNEL",
    "SCENE_CHANNEL",
    "Converted",
    "Converter",
    "TraceOptions",
    "local_path",
    "location_fix",
    "pose",
    "pose_in_frame",
    "scene_entity",
    "trace_options",
]

LOCATION_CHANNEL = "mcs/location"
POSE_CHANNEL = "mcs/pose"
PATH_CHANNEL = "mcs/path"  # mcs/path/<label>: local east/north/up points, for plots
TRAJECTORY_CHANNEL = "mcs/trajectory"
PLAN_CHANNEL = "mcs/plan"
OBSTACLES_CHANNEL = "mcs/obstacles"
SCENE_CHANNEL = "mcs/scene"  # 3-D entities (the obstacles) for the 3D panel
ROBUSTNESS_CHANNEL = "mcs/robustness"
# An attack's window: {"sensor", "model", "start", "end"} (s; end None: to the end of the run).
ATTACK_CHANNEL = "mcs/attack"
# mcs/encounter/<a>/<b>: a pair of a fleet's vehicles each sample (their separation, ...)
ENCOUNTER_CHANNEL = "mcs/encounter"


@dataclasses.dataclass(frozen=True)
class Converted:
    """One message a converter derives from a recorded one."""

    channel: str
    schema: Schema
    message: Mapping[str, Any]


class Converter(Protocol):
    """Derives messages (e.g. Foxglove well-known ones) from the messages of ``topics``.

    It is called at save time, in time order, with the message as JSON-like builtins (what
    the topic's channel shows: objects as dicts; ``bytes`` fields stay bytes), so it works
    the same for in-process and process publishers.
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
        return fix_message(time_ns, *fix, frame_id=frame_id)

    return _FieldConverter((topic,), channel, build, LOCATION_FIX)


def fix_message(
    time_ns: int, lat: float, lon: float, alt: float, *, frame_id: str = "base_link"
) -> dict[str, Any]:
    """A ``foxglove.LocationFix`` message (no covariance known)."""
    return {
        "timestamp": stamp(time_ns),
        "frame_id": frame_id,
        "latitude": float(lat),
        "longitude": float(lon),
        "altitude": float(alt),
        "position_covariance": [0.0] * 9,
        "position_covariance_type": 0,
    }


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
        return pose_message(time_ns, *found, frame_id=frame_id)

    return _FieldConverter((topic,), channel, build, POSE_IN_FRAME)


def pose_message(
    time_ns: int,
    position: Sequence[float],
    orientation: Sequence[float],
    *,
    frame_id: str = "map",
) -> dict[str, Any]:
    """A ``foxglove.PoseInFrame`` message; ``orientation`` is (w, x, y, z)."""
    return {"timestamp": stamp(time_ns), "frame_id": frame_id, "pose": pose(position, orientation)}


def pose(position: Sequence[float], orientation: Sequence[float]) -> dict[str, Any]:
    """A ``foxglove.Pose``: ``position`` (x, y, z) and ``orientation`` (w, x, y, z)."""
    px, py, pz = position
    qw, qx, qy, qz = orientation
    return {
        "position": {"x": float(px), "y": float(py), "z": float(pz)},
        "orientation": {"x": float(qx), "y": float(qy), "z": float(qz), "w": float(qw)},
    }


def scene_entity(
    time_ns: int,
    entity_id: str,
    *,
    cubes: Sequence[Mapping[str, Any]] = (),
    cylinders: Sequence[Mapping[str, Any]] = (),
    metadata: Mapping[str, str] | None = None,
    frame_id: str = "map",
) -> dict[str, Any]:
    """A ``foxglove.SceneEntity`` of ``cubes`` and ``cylinders`` (``foxglove.CubePrimitive``,
    ``foxglove.CylinderPrimitive``) that stays until replaced; ``metadata`` as key-value pairs.
    """
    return {
        "timestamp": stamp(time_ns),
        "frame_id": frame_id,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},  # zero: forever
        "frame_locked": False,
        "metadata": [{"key": k, "value": v} for k, v in (metadata or {}).items()],
        "arrows": [],
        "cubes": [dict(c) for c in cubes],
        "spheres": [],
        "cylinders": [dict(c) for c in cylinders],
        "lines": [],
        "triangles": [],
        "texts": [],
        "models": [],
    }


def local_path(
    topic: str, position: Callable[[Any], tuple[float, float, float] | None], *, label: str
) -> Converter:
    """A path channel ``mcs/path/LABEL`` from ``topic``, which the trace's plot draws.

    ``position(message)`` returns (east, north, up) in metres from the scenario's local
    origin, or None to skip the message. Label paths by what they are (``truth``,
    ``estimate``, ``sensed``).
    """

    def build(message: Any, time_ns: int) -> Mapping[str, Any] | None:
        point = position(message)
        if point is None:
            return None
        east, north, up = (float(v) for v in point)
        return {"east": east, "north": north, "up": up}

    return _FieldConverter((topic,), f"{PATH_CHANNEL}/{label}", build, PATH_POINT)


@dataclasses.dataclass(frozen=True)
class TraceOptions:
    """What a scenario tells the recorder about its topics.

    ``types`` maps topics to message types; ``converters`` derive more channels; ``plan`` is
    a planned path, points (east, north[, up]) in metres in the local frame; ``replaced``
    topics are written only as what their converters derive (a MAVLink link, decoded into a
    channel per message type); the MAVLink frames of the ``tlog`` topics (a ``data`` bytes
    field) also go to a ``.tlog`` beside the trace; ``plots`` are the (title, message paths)
    that its Foxglove layout plots, e.g. a setpoint beside the value it commands.
    ``deterministic`` is False where real firmware flies on its own threads (PX4,
    ArduPilot): two runs of one seed then route other samples, and only their verdicts are
    held to be the same (``--mcs-repeat``).

    A simulation offers them with a ``trace_options()`` method; recorders attached to it use
    them (their own ``types`` and ``converters`` take precedence).
    """

    types: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    converters: Sequence[Converter] = ()
    plan: Sequence[Sequence[float]] = ()
    replaced: Sequence[str] = ()
    tlog: Sequence[str] = ()
    plots: Sequence[tuple[str, Sequence[str]]] = ()
    deterministic: bool = True


def trace_options(simulation: object) -> TraceOptions:
    """The trace options of ``simulation``: its own ``trace_options()`` with those its nodes
    offer (an FMU node's channel types, for example); empty if there are none.

    Where both give a topic's type, the simulation's own wins.
    """
    own = _offered(simulation, "trace_options()")
    offered = [
        _offered(node, f"trace_options() of node {getattr(node, 'name', node)!r}")
        for node in _nodes(simulation)
    ]
    found = [o for o in offered if o is not None]
    if not found:
        return own or TraceOptions()
    if own is not None:
        found.append(own)
    return merge_options(found, plan=own.plan if own is not None else ())


def merge_options(
    options: Sequence[TraceOptions], plan: Sequence[Sequence[float]] = ()
) -> TraceOptions:
    """One set of trace options from several (a fleet's vehicles', a simulation's nodes'):
    every type (the last given wins), converter, plot and log; deterministic where all are."""
    types: dict[str, Any] = {}
    for o in options:
        types.update(o.types)
    return TraceOptions(
        types=types,
        converters=[c for o in options for c in o.converters],
        plan=plan,
        replaced=[t for o in options for t in o.replaced],
        tlog=[t for o in options for t in o.tlog],
        plots=[p for o in options for p in o.plots],
        deterministic=all(o.deterministic for o in options),
    )


def _offered(source: object, what: str) -> TraceOptions | None:
    method = getattr(source, "trace_options", None)
    options = method() if callable(method) else None
    if options is not None and not isinstance(options, TraceOptions):
        raise ConfigurationError(what, options, "a multicosim.trace.TraceOptions (or None)")
    return options


def _nodes(simulation: object) -> list[object]:
    """The nodes of ``simulation`` (or of the simulation a scenario wraps)."""
    seen: set[int] = set()
    current: object = simulation
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        nodes = getattr(current, "nodes", None)
        if isinstance(nodes, list):
            return nodes
        current = getattr(current, "simulation", None)
    return []
