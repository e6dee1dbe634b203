"""What a trace of a MAVLink autopilot's mission shows, in channels Foxglove understands
(PX4's and ArduPilot's scenarios use it). ``VEHICLE`` is the vehicle's name (``px4``,
``ardupilot``): its channels are under it.

* The MAVLink links between ground station and autopilot (``VEHICLE/mavlink/up`` and
  ``down``), and the HIL frames between world and autopilot where they travel as MAVLink,
  are decoded into one channel per message type (``VEHICLE/mavlink/down/ATTITUDE``, ...),
  each with a JSON schema generated from pymavlink's message definitions. The links also go
  to a ``.tlog``.
* ``VEHICLE/log``: the autopilot's STATUSTEXT as ``foxglove.Log``.
* ``VEHICLE/pose``: the autopilot's attitude (ATTITUDE_QUATERNION, else ATTITUDE) at its
  estimated position, as ``foxglove.PoseInFrame`` in an east-north-up ``map`` frame (FLU body).
* ``VEHICLE/location/estimate`` (GLOBAL_POSITION_INT) and ``VEHICLE/location/truth`` (the
  world's truth): two ``foxglove.LocationFix`` tracks; ``mcs/path/estimate`` and
  ``mcs/path/truth`` the same in metres from home, for the plot.
* ``mcs/obstacles``: the world's obstacles (footprints and heights), for the plot; ``mcs/scene``
  the same as ``foxglove.SceneUpdate`` (a cube or cylinder each, in ``map``) for the 3D panel.
* ``VEHICLE/mission``: the uploaded mission (MISSION_ITEM_INT) as ``foxglove.GeoJSON`` for
  the Map panel, and ``mcs/plan`` for the plot.
* The layout plots each position setpoint (POSITION_TARGET_LOCAL_NED) beside the estimate.
"""

from __future__ import annotations

import functools
import inspect
import json
import math
from collections.abc import Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

from ..core.geo import LocalProjection, quaternion_from_euler, swap_attitude_frames
from ..physics.obstacles import Obstacle, Placed, placed
from ..trace import (
    DIALECT,
    GEOJSON,
    LOCATION_FIX,
    LOG,
    OBSTACLES,
    OBSTACLES_CHANNEL,
    PATH_CHANNEL,
    PATH_POINT,
    PLAN,
    PLAN_CHANNEL,
    POSE_IN_FRAME,
    SCENE_CHANNEL,
    SCENE_UPDATE,
    Converted,
    Schema,
    TraceOptions,
    fix_message,
    message_path,
    pose,
    pose_message,
    scene_entity,
    stamp,
)
from .dialect import decode_frames, dialect, new_link
from .hil import MavlinkPacket, Truth

if TYPE_CHECKING:
    from ..core.geo import Home

__all__ = ["Channels", "mavlink_message", "mavlink_schema", "mission_trace"]


class Channels(NamedTuple):
    """A vehicle's Foxglove channels (see the module); ``paths`` and ``plan`` are where its
    paths and plan for the plot go (under its name too, for a vehicle of a fleet)."""

    vehicle: str
    log: str
    pose: str
    estimate: str
    truth: str
    mission: str
    paths: str = PATH_CHANNEL
    plan: str = PLAN_CHANNEL

    @classmethod
    def of(cls, vehicle: str, *, member: bool = False) -> Channels:
        """The channels under ``vehicle``'s name (``member``: of a fleet, the plot's too)."""
        return cls(
            vehicle,
            f"{vehicle}/log",
            f"{vehicle}/pose",
            f"{vehicle}/location/estimate",
            f"{vehicle}/location/truth",
            f"{vehicle}/mission",
            f"{PATH_CHANNEL}/{vehicle}" if member else PATH_CHANNEL,
            f"{PLAN_CHANNEL}/{vehicle}" if member else PLAN_CHANNEL,
        )


# Obstacles in the 3D panel: the plot's brown, see-through.
_OBSTACLE_COLOR = {"r": 0.55, "g": 0.34, "b": 0.29, "a": 0.6}
# MAV_SEVERITY (0 emergency .. 7 debug) -> foxglove.LogLevel (1 debug .. 5 fatal).
_LOG_LEVEL = {0: 5, 1: 5, 2: 5, 3: 4, 4: 3, 5: 2, 6: 2, 7: 1}
# C types of MAVLink fields: JSON integer bounds.
_INT_RANGE = {
    "int8_t": (-(2**7), 2**7 - 1),
    "uint8_t": (0, 2**8 - 1),
    "int16_t": (-(2**15), 2**15 - 1),
    "uint16_t": (0, 2**16 - 1),
    "int32_t": (-(2**31), 2**31 - 1),
    "uint32_t": (0, 2**32 - 1),
    "int64_t": (-(2**63), 2**63 - 1),
    "uint64_t": (0, 2**64 - 1),
}


# -- MAVLink messages as typed JSON ---------------------------------------------------------


@functools.cache
def mavlink_schema(cls: Any) -> Schema:
    """The JSON schema of a pymavlink message class, from its field definitions.

    Integers carry their C type's range, floats may be null (NaN means "unset" in MAVLink),
    ``char`` arrays are strings; descriptions name units, enums and bitmasks.
    """
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    properties: dict[str, Any] = {}
    for name, ctype in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        length = lengths.get(name, 0)
        if ctype == "char":
            item: dict[str, Any] = {"type": "string", "maxLength": max(length, 1)}
        else:
            bounds = _INT_RANGE.get(ctype)
            base: dict[str, Any] = (
                {"type": "integer", "minimum": bounds[0], "maximum": bounds[1]}
                if bounds is not None
                else {"type": ["number", "null"]}
            )
            item = (
                {"type": "array", "items": base, "minItems": length, "maxItems": length}
                if length
                else base
            )
        notes = [f"C type {ctype}" + (f"[{length}]" if length else "")]
        if cls.fieldunits_by_name.get(name):
            notes.append(f"unit {cls.fieldunits_by_name[name]}")
        if cls.fieldenums_by_name.get(name):
            kind = "bitmask of" if cls.fielddisplays_by_name.get(name) == "bitmask" else "enum"
            notes.append(f"{kind} {cls.fieldenums_by_name[name]}")
        item["description"] = ", ".join(notes)
        properties[name] = item
    title = f"mavlink.common.{cls.msgname}"
    return Schema(
        title,
        {
            "$schema": DIALECT,
            "title": title,
            "description": inspect.cleandoc(cls.__doc__ or cls.msgname),
            "type": "object",
            "properties": properties,
            "required": list(cls.fieldnames),
        },
    )


def mavlink_message(m: Any) -> dict[str, Any]:
    """A decoded pymavlink message as a JSON-ready dict of its fields (NaN becomes null)."""
    out: dict[str, Any] = {}
    for name in m.fieldnames:
        value = getattr(m, name)
        if isinstance(value, bytes | bytearray):
            value = bytes(value).split(b"\0", 1)[0].decode("utf-8", "replace")
        out[name] = value
    return out


# -- attitude -------------------------------------------------------------------------------


# -- the converters -------------------------------------------------------------------------


class _Links:
    """Decodes MAVLink topics into per-type channels and derives the Foxglove channels."""

    def __init__(
        self,
        topics: tuple[str, ...],
        uplink: str,
        downlink: str,
        home: Home,
        channels: Channels,
        dialect_name: str = "common",
        start: Home | None = None,
    ) -> None:
        self.topics = topics
        self._channels = channels
        self._dialect = dialect_name
        self._uplink = uplink
        self._downlink = downlink
        self._parsers: dict[str, Any] = {}
        self._home = start or home  # the vehicle's own, where it started
        self._projection = LocalProjection(home.lat, home.lon)
        # Where the vehicle's local frame (its start) is in the world's: east, north, up.
        north, east = self._projection.project(self._home.lat, self._home.lon)
        self._origin = (east, north, self._home.alt - home.alt)
        self._local: Any = None
        self._quaternions = False
        self._items: dict[int, Any] = {}
        self._count = 0

    def __call__(self, topic: str, time_ns: int, message: Any) -> Iterable[Converted]:
        data = message.get("data") if isinstance(message, dict) else None
        if not isinstance(data, bytes):
            return ()
        parser = self._parsers.get(topic)
        if parser is None:
            parser = self._parsers[topic] = new_link(0, 0, self._dialect)
        return list(self._convert(topic, time_ns, decode_frames(parser, data)))

    def _convert(self, topic: str, time_ns: int, decoded: list[Any]) -> Iterator[Converted]:
        for m in decoded:
            kind = m.get_type()
            if kind == "BAD_DATA":
                continue
            cls: Any = type(m)
            yield Converted(f"{topic}/{kind}", mavlink_schema(cls), mavlink_message(m))
            if topic == self._downlink:
                yield from self._downlink_message(kind, m, time_ns)
            elif topic == self._uplink:
                yield from self._uplink_message(kind, m, time_ns)

    def _downlink_message(self, kind: str, m: Any, time_ns: int) -> Iterator[Converted]:
        if kind == "STATUSTEXT":
            yield Converted(
                self._channels.log,
                LOG,
                {
                    "timestamp": stamp(time_ns),
                    "level": _LOG_LEVEL.get(int(m.severity), 0),
                    "message": mavlink_message(m)["text"],
                    "name": f"{self._channels.vehicle} (system {m.get_srcSystem()})",
                    "file": "",
                    "line": 0,
                },
            )
        elif kind == "LOCAL_POSITION_NED":
            self._local = m
        elif kind == "ATTITUDE_QUATERNION":
            self._quaternions = True
            yield from self._pose(time_ns, (m.q1, m.q2, m.q3, m.q4))
        elif kind == "ATTITUDE" and not self._quaternions:
            yield from self._pose(time_ns, quaternion_from_euler(m.roll, m.pitch, m.yaw))
        elif kind == "GLOBAL_POSITION_INT":
            lat, lon = m.lat * 1e-7, m.lon * 1e-7
            yield Converted(
                self._channels.estimate, LOCATION_FIX, fix_message(time_ns, lat, lon, m.alt * 1e-3)
            )
            north, east = self._projection.project(lat, lon)
            up = m.relative_alt * 1e-3 + self._origin[2]
            yield Converted(
                f"{self._channels.paths}/estimate",
                PATH_POINT,
                {"east": east, "north": north, "up": up},
            )

    def _pose(self, time_ns: int, q_ned_frd: tuple[float, ...]) -> Iterator[Converted]:
        local = self._local
        if local is None or not all(math.isfinite(v) for v in q_ned_frd):
            return
        e, n, u = self._origin
        position = (local.y + e, local.x + n, -local.z + u)  # NED -> ENU, from the world's home
        yield Converted(
            self._channels.pose,
            POSE_IN_FRAME,
            pose_message(time_ns, position, swap_attitude_frames(q_ned_frd)),
        )

    def _uplink_message(self, kind: str, m: Any, time_ns: int) -> Iterator[Converted]:
        if kind == "MISSION_COUNT" and m.mission_type == 0:
            self._count = int(m.count)
            self._items = {}
        elif kind == "MISSION_ITEM_INT" and m.mission_type == 0:
            self._items[int(m.seq)] = m
            yield from self._mission(time_ns)

    def _mission(self, time_ns: int) -> Iterator[Converted]:
        """The mission uploaded so far: takeoff, waypoints, then land or return."""
        home = self._home
        origin = self._origin
        points: list[tuple[float, float, float]] = [origin]  # east, north, up
        coordinates = [[home.lon, home.lat]]
        features: list[dict[str, Any]] = []
        alt = 0.0
        for seq in sorted(self._items):
            item = self._items[seq]
            command = dialect().enums["MAV_CMD"].get(int(item.command))
            name = (
                command.name.removeprefix("MAV_CMD_") if command is not None else str(item.command)
            )
            if int(item.command) == 20:  # return to launch
                lat, lon = home.lat, home.lon
            elif item.x == 0 and item.y == 0:  # no position: where the vehicle is
                lon, lat = coordinates[-1]
            else:
                lat, lon = item.x * 1e-7, item.y * 1e-7
            alt = float(item.z) if int(item.command) != 21 else 0.0
            if int(item.command) == 20:
                points.append((origin[0], origin[1], points[-1][2]))
                alt = 0.0
            north, east = self._projection.project(lat, lon)
            points.append((east, north, alt + origin[2]))
            coordinates.append([lon, lat])
            features.append(
                {
                    "type": "Feature",
                    "geometry": {"type": "Point", "coordinates": [lon, lat]},
                    "properties": {"name": f"{seq}: {name} at {alt:g} m"},
                }
            )
        line = {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": coordinates},
            "properties": {"name": "mission", "style": {"color": "#ff7f0e", "dashArray": "6 4"}},
        }
        collection = {"type": "FeatureCollection", "features": [line, *features]}
        yield Converted(self._channels.mission, GEOJSON, {"geojson": json.dumps(collection)})
        plan = [{"east": e, "north": n, "up": u} for e, n, u in points]
        yield Converted(self._channels.plan, PLAN, {"points": plan})


def _obstacle_entity(time_ns: int, p: Placed) -> dict[str, Any]:
    """A placed obstacle as a ``foxglove.SceneEntity`` in the east-north-up ``map`` frame: a
    cube (``length`` along its x axis, turned to the box's yaw) or a cylinder, standing on the
    ground, with the obstacle's label as its id.
    """
    centre = (p.east, p.north, p.height / 2)
    metadata = {"name": p.label, "number": str(p.number)}
    if p.radius:
        cylinder = {
            "pose": pose(centre, (1.0, 0.0, 0.0, 0.0)),
            "size": {"x": 2 * p.radius, "y": 2 * p.radius, "z": p.height},
            "bottom_scale": 1.0,
            "top_scale": 1.0,
            "color": _OBSTACLE_COLOR,
        }
        return scene_entity(time_ns, p.label, cylinders=[cylinder], metadata=metadata)
    # A box's axis at yaw is a FLU body's x axis heading that way: the pose's projection.
    turn = swap_attitude_frames(quaternion_from_euler(0.0, 0.0, p.yaw))
    cube = {
        "pose": pose(centre, turn),
        "size": {"x": 2 * p.half_length, "y": 2 * p.half_width, "z": p.height},
        "color": _OBSTACLE_COLOR,
    }
    return scene_entity(time_ns, p.label, cubes=[cube], metadata=metadata)


class _Truth:
    """The world's truth as a LocationFix track and a path in metres from home; with its
    first message, the world's obstacles (for the plot and as a 3-D scene)."""

    def __init__(
        self, topic: str, home: Home, obstacles: Sequence[Obstacle], channels: Channels
    ) -> None:
        self.topics = (topic,)
        self._channel = channels.truth
        self._path = f"{channels.paths}/truth"
        self._home_alt = home.alt
        self._obstacles = placed(obstacles, home)

    def _scene(self, time_ns: int) -> Iterator[Converted]:
        if not self._obstacles:
            return
        shapes = [
            {
                "name": p.label,
                "height": p.height,
                "footprint": [{"east": e, "north": n, "up": 0.0} for n, e in p.corners()],
            }
            for p in self._obstacles
        ]
        yield Converted(OBSTACLES_CHANNEL, OBSTACLES, {"obstacles": shapes})
        entities = [_obstacle_entity(time_ns, p) for p in self._obstacles]
        yield Converted(SCENE_CHANNEL, SCENE_UPDATE, {"deletions": [], "entities": entities})

    def __call__(self, topic: str, time_ns: int, message: Any) -> Iterable[Converted]:
        m = message
        once = list(self._scene(time_ns))
        self._obstacles = []
        return (
            *once,
            Converted(
                self._channel,
                LOCATION_FIX,
                fix_message(time_ns, m["lat"], m["lon"], self._home_alt + m["alt"]),
            ),
            Converted(
                self._path,
                PATH_POINT,
                {"east": m["east"], "north": m["north"], "up": m["alt"]},
            ),
        )


def mission_trace(
    *,
    vehicle: str,
    uplink: str,
    downlink: str,
    truth: str,
    home: Home,
    types: dict[str, Any],
    links: tuple[str, ...] | None = None,
    dialect_name: str = "common",
    obstacles: Sequence[Obstacle] = (),
    member: bool = False,
    start: Home | None = None,
) -> TraceOptions:
    """Trace options of a ground station's MAVLink link and the world's truth (any autopilot).

    ``vehicle`` names the vehicle's channels (see the module); ``links`` are the MAVLink
    topics decoded into channels (default: the uplink and the downlink); ``types`` the other
    topics' message types; ``obstacles`` the world's (their footprints go to
    ``mcs/obstacles``, for the plot, their solids to ``mcs/scene``, for the 3D panel).
    A ``member`` of a fleet has its paths and plan under its name (``mcs/path/alpha/truth``)
    and starts at ``start`` (None: ``home``, the world's origin).
    """
    links = links or (uplink, downlink)
    channels = Channels.of(vehicle, member=member)
    types = {**types, truth: Truth, uplink: MavlinkPacket, downlink: MavlinkPacket}
    target = f"{downlink}/POSITION_TARGET_LOCAL_NED"
    local = f"{downlink}/LOCAL_POSITION_NED"
    whose = f"{vehicle}: " if member else ""
    plots = [
        (
            f"{whose}{axis}: setpoint vs estimate (local NED, m)",
            [message_path(target, field), message_path(local, field)],
        )
        for axis, field in (("north", "x"), ("east", "y"), ("down", "z"))
    ]
    plots.append(
        (
            f"{whose}height above home: estimate vs truth (m)",
            [
                message_path(f"{channels.paths}/estimate", "up"),
                message_path(f"{channels.paths}/truth", "up"),
            ],
        )
    )
    return TraceOptions(
        types=types,
        converters=[
            _Links(links, uplink, downlink, home, channels, dialect_name, start),
            _Truth(truth, home, obstacles, channels),
        ],
        replaced=links,
        tlog=(uplink, downlink),
        plots=plots,
    )
