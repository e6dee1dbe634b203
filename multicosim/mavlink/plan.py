"""QGroundControl ``.plan`` files: a mission, its geofence and rally points, in and out.

A plan is JSON (``fileType: "Plan"``, version 1) with three parts, as QGroundControl saves
them: ``mission`` (its items, ``plannedHomePosition``, ``cruiseSpeed``/``hoverSpeed``),
``geoFence`` (inclusion and exclusion polygons and circles) and ``rallyPoints``. A
``Plan`` holds what a vehicle flies: the simple items as MAVLink mission items (all
seven parameters, the frame as saved), with DO_JUMP targets as indices into ``items``
(QGroundControl numbers them by ``doJumpId``, home being 0). Complex items (survey, corridor
and structure scans) are saved unexpanded: QGroundControl computes their waypoints when it
uploads, so a plan that holds one is refused, as is a command MAVLink does not define.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Literal

import msgspec

from ..core.errors import ConfigurationError
from ..core.fields import FieldReader
from .dialect import (
    CMD_DO_JUMP,
    CMD_FENCE_CIRCLE_EXCLUSION,
    CMD_FENCE_CIRCLE_INCLUSION,
    CMD_FENCE_POLYGON_EXCLUSION,
    CMD_FENCE_POLYGON_INCLUSION,
    CMD_LAND,
    CMD_LOITER_TIME,
    CMD_LOITER_TO_ALT,
    CMD_LOITER_UNLIM,
    CMD_RALLY_POINT,
    CMD_RTL,
    CMD_WAYPOINT,
    FRAME_GLOBAL,
    FRAME_GLOBAL_INT,
    FRAME_GLOBAL_REL,
    FRAME_GLOBAL_REL_INT,
    FRAME_MISSION,
    dialect,
)

__all__ = [
    "FenceCircle",
    "FencePolygon",
    "Params",
    "Plan",
    "PlanItem",
    "RallyPoint",
    "command_name",
    "read_plan",
    "write_plan",
]

PLAN_FRAMES = {
    FRAME_GLOBAL: "AMSL",
    FRAME_MISSION: "no position",
    FRAME_GLOBAL_REL: "relative to home",
    FRAME_GLOBAL_INT: "AMSL",
    FRAME_GLOBAL_REL_INT: "relative to home",
}
"""The frames a plan's items may use (terrain frames need terrain data we do not have)."""

AMSL_FRAMES = (FRAME_GLOBAL, FRAME_GLOBAL_INT)
WAYPOINT_COMMANDS = (CMD_WAYPOINT, CMD_LOITER_TIME, CMD_LOITER_UNLIM, CMD_LOITER_TO_ALT)
"""The items a plan's waypoints are made of (where the vehicle flies to and may stay)."""

# QGroundControl's AltitudeMode of an item: 1 relative to home, 2 AMSL.
_QGC_ALTITUDE_MODE = {
    FRAME_GLOBAL_REL: 1,
    FRAME_GLOBAL_REL_INT: 1,
    FRAME_GLOBAL: 2,
    FRAME_GLOBAL_INT: 2,
}


def command_name(command: int) -> str:
    """MAVLink's name of ``command`` (``MAV_CMD_NAV_WAYPOINT``), "" if MAVLink has none."""
    entry = dialect("ardupilotmega").enums["MAV_CMD"].get(command)
    name: str = entry.name if entry is not None and not entry.name.endswith("ENUM_END") else ""
    return name


def has_position(item: PlanItem) -> bool:
    """Whether ``item`` names a place: a latitude and longitude, set and not both zero (PX4
    lands or takes off where the vehicle is when they are zero or unset)."""
    lat, lon = item.lat, item.lon
    return math.isfinite(lat) and math.isfinite(lon) and (lat, lon) != (0.0, 0.0)


Params = tuple[float, float, float, float, float, float, float]
"""A mission item's seven parameters (5-7: latitude, longitude, altitude)."""


class PlanItem(msgspec.Struct, frozen=True):
    """A mission item: MAVLink ``command`` in ``frame`` with params 1-7 (5-7: lat, lon, alt).

    ``NaN`` stands for a parameter QGroundControl leaves unset (``null``); for DO_JUMP,
    param 1 is the index of the target in ``Plan.items``.
    """

    command: int
    frame: int
    params: Params
    autocontinue: bool = True

    @property
    def lat(self) -> float:
        """Latitude (deg)."""
        return self.params[4]

    @property
    def lon(self) -> float:
        """Longitude (deg)."""
        return self.params[5]

    @property
    def alt(self) -> float:
        """Altitude (m) in the item's frame."""
        return self.params[6]


class FencePolygon(msgspec.Struct, frozen=True):
    """A geofence polygon: its vertices (lat, lon in degrees); the vehicle stays in or out."""

    vertices: list[tuple[float, float]]
    inclusion: bool = True


class FenceCircle(msgspec.Struct, frozen=True):
    """A geofence circle around (lat, lon) of ``radius`` m; the vehicle stays in or out."""

    lat: float
    lon: float
    radius: float
    inclusion: bool = True


class RallyPoint(msgspec.Struct, frozen=True):
    """A safe point to return to: lat, lon (deg), altitude above home (m)."""

    lat: float
    lon: float
    alt: float


class Plan(msgspec.Struct, frozen=True, kw_only=True):
    """A QGroundControl plan: mission items, planned home, speeds, geofence, rally points.

    ``home`` is ``plannedHomePosition`` (lat, lon in degrees, altitude AMSL in m).
    """

    items: list[PlanItem]
    home: tuple[float, float, float]
    cruise_speed: float = 15.0
    hover_speed: float = 5.0
    polygons: list[FencePolygon] = msgspec.field(default_factory=list)
    circles: list[FenceCircle] = msgspec.field(default_factory=list)
    rally: list[RallyPoint] = msgspec.field(default_factory=list)
    vehicle_type: int = 2
    firmware_type: int = 12

    def relative_alt(self, item: PlanItem) -> float:
        """The item's altitude above home (m), whatever its frame."""
        return item.alt - self.home[2] if item.frame in AMSL_FRAMES else item.alt

    def waypoints(self) -> list[int]:
        """Indices of the items that take the vehicle somewhere: waypoints and loiters, and
        a landing at a position of its own (PX4 flies there, then lands: the last leg of a
        plan that may have no waypoint at all)."""
        return [
            i
            for i, it in enumerate(self.items)
            if it.command in WAYPOINT_COMMANDS or (it.command == CMD_LAND and has_position(it))
        ]

    def end(self) -> Literal["land", "rtl", "hold"]:
        """How the mission ends: ``"land"``, ``"rtl"`` or ``"hold"`` (at its last item)."""
        for it in reversed(self.items):
            if it.command == CMD_LAND:
                return "land"
            if it.command == CMD_RTL:
                return "rtl"
            if it.command in WAYPOINT_COMMANDS:
                break
        return "hold"

    def fence_items(self) -> list[PlanItem]:
        """The geofence as MAVLink fence items (MISSION_TYPE_FENCE), polygons first.

        Frames are those QGroundControl sends (and PX4's RTL reads rally points in).
        """
        out: list[PlanItem] = []
        for group, poly in enumerate(self.polygons):
            cmd = CMD_FENCE_POLYGON_INCLUSION if poly.inclusion else CMD_FENCE_POLYGON_EXCLUSION
            # param 1: the vertex count; param 2: the inclusion group (one per polygon)
            count, grp = float(len(poly.vertices)), float(group if poly.inclusion else 0)
            out += [
                PlanItem(cmd, FRAME_GLOBAL, (count, grp, 0.0, 0.0, lat, lon, 0.0))
                for lat, lon in poly.vertices
            ]
        for c in self.circles:
            cmd = CMD_FENCE_CIRCLE_INCLUSION if c.inclusion else CMD_FENCE_CIRCLE_EXCLUSION
            out.append(PlanItem(cmd, FRAME_GLOBAL, (c.radius, 0.0, 0.0, 0.0, c.lat, c.lon, 0.0)))
        return out

    def rally_items(self) -> list[PlanItem]:
        """The rally points as MAVLink items (MISSION_TYPE_RALLY, altitude above home)."""
        return [
            PlanItem(CMD_RALLY_POINT, FRAME_GLOBAL_REL, (0.0, 0.0, 0.0, 0.0, r.lat, r.lon, r.alt))
            for r in self.rally
        ]


# -- reading --------------------------------------------------------------------------------


class _Reader(FieldReader):
    """Reads one plan file, naming the file and the JSON path of whatever is wrong."""

    MAPPING = "a JSON object"
    LIST = "a JSON array"

    def coordinate(self, where: str, value: object) -> tuple[float, float]:
        pair = self.lst(where, value)
        if len(pair) < 2:
            raise self.fail(where, value, "[latitude, longitude, ...]")
        lat, lon = self.num(f"{where}[0]", pair[0]), self.num(f"{where}[1]", pair[1])
        if not -90 <= lat <= 90 or not -180 <= lon <= 180:
            raise self.fail(where, value, "a latitude in [-90, 90] and a longitude in [-180, 180]")
        return lat, lon

    def plan(self, doc: object) -> Plan:
        top = self.obj("(top level)", doc)
        if top.get("fileType") != "Plan":
            raise self.fail("fileType", top.get("fileType"), '"Plan" (a QGroundControl plan)')
        if top.get("version") != 1:
            raise self.fail("version", top.get("version"), "1")
        mission = self.obj("mission", top.get("mission"))
        home_raw = self.lst("mission.plannedHomePosition", mission.get("plannedHomePosition"))
        lat, lon = self.coordinate("mission.plannedHomePosition", home_raw)
        alt = self.num("mission.plannedHomePosition[2]", home_raw[2] if len(home_raw) > 2 else None)
        speeds = {}
        for key in ("cruiseSpeed", "hoverSpeed"):
            value = self.num(f"mission.{key}", mission.get(key, 5.0))
            if value <= 0:
                raise self.fail(f"mission.{key}", value, "a speed above 0 m/s")
            speeds[key] = value
        items = self.items(self.lst("mission.items", mission.get("items", [])))
        fence = self.obj("geoFence", top.get("geoFence", {}))
        rally = self.obj("rallyPoints", top.get("rallyPoints", {}))
        return Plan(
            items=items,
            home=(lat, lon, alt),
            cruise_speed=speeds["cruiseSpeed"],
            hover_speed=speeds["hoverSpeed"],
            polygons=[
                self.polygon(f"geoFence.polygons[{i}]", p)
                for i, p in enumerate(self.lst("geoFence.polygons", fence.get("polygons", [])))
            ],
            circles=[
                self.circle(f"geoFence.circles[{i}]", c)
                for i, c in enumerate(self.lst("geoFence.circles", fence.get("circles", [])))
            ],
            rally=[
                self.rally_point(f"rallyPoints.points[{i}]", p)
                for i, p in enumerate(self.lst("rallyPoints.points", rally.get("points", [])))
            ],
            vehicle_type=int(self.num("mission.vehicleType", mission.get("vehicleType", 2))),
            firmware_type=int(self.num("mission.firmwareType", mission.get("firmwareType", 12))),
        )

    def items(self, raw: list[Any]) -> list[PlanItem]:
        items: list[PlanItem] = []
        jump_ids: dict[int, int] = {}
        for i, entry in enumerate(raw):
            where = f"mission.items[{i}]"
            obj = self.obj(where, entry)
            kind = obj.get("type")
            if kind == "ComplexItem":
                raise self.fail(
                    f"{where}.complexItemType",
                    obj.get("complexItemType"),
                    "simple items only: QGroundControl saves a survey, corridor scan or "
                    "structure scan unexpanded and computes its waypoints only when it "
                    "uploads; upload it from QGroundControl and save the mission it reads "
                    "back from the vehicle",
                )
            if kind != "SimpleItem":
                raise self.fail(f"{where}.type", kind, '"SimpleItem"')
            command = obj.get("command")
            if isinstance(command, bool) or not isinstance(command, int):
                raise self.fail(f"{where}.command", command, "a MAVLink command number")
            if not command_name(command):
                raise self.fail(f"{where}.command", command, "a command MAVLink defines (MAV_CMD)")
            frame = obj.get("frame")
            if frame not in PLAN_FRAMES:
                raise self.fail(
                    f"{where}.frame",
                    frame,
                    "0 (AMSL), 2 (no position), 3 (relative to home) or their _INT variants 5, 6",
                )
            raw_params = self.lst(f"{where}.params", obj.get("params"))
            if len(raw_params) != 7:
                raise self.fail(f"{where}.params", raw_params, "seven parameters")
            p1, p2, p3, p4, lat, lon, alt = (
                self.num(f"{where}.params[{k}]", v, null=True) for k, v in enumerate(raw_params)
            )
            # An unset position is none: 0, as MAVLink sends it.
            lat, lon, alt = (0.0 if math.isnan(v) else v for v in (lat, lon, alt))
            params = (p1, p2, p3, p4, lat, lon, alt)
            if frame != FRAME_MISSION and not (-90 <= params[4] <= 90 and -180 <= params[5] <= 180):
                raise self.fail(f"{where}.params", raw_params, "a latitude and longitude in range")
            jump_id = obj.get("doJumpId", i + 1)
            if isinstance(jump_id, int) and not isinstance(jump_id, bool):
                jump_ids[jump_id] = len(items)
            autocontinue = bool(obj.get("autoContinue", True))
            items.append(PlanItem(command, int(frame), params, autocontinue))
        for i, it in enumerate(items):
            if it.command == CMD_DO_JUMP:
                target = jump_ids.get(int(it.params[0]) if math.isfinite(it.params[0]) else -1)
                if target is None:
                    raise self.fail(
                        f"mission.items[{i}].params[0]",
                        it.params[0],
                        f"the doJumpId of an item of the mission ({sorted(jump_ids)})",
                    )
                items[i] = msgspec.structs.replace(it, params=(float(target), *it.params[1:]))
        return items

    def polygon(self, where: str, raw: object) -> FencePolygon:
        obj = self.obj(where, raw)
        vertices = [
            self.coordinate(f"{where}.polygon[{k}]", v)
            for k, v in enumerate(self.lst(f"{where}.polygon", obj.get("polygon")))
        ]
        if len(vertices) < 3:
            raise self.fail(f"{where}.polygon", obj.get("polygon"), "at least three vertices")
        return FencePolygon(vertices, bool(obj.get("inclusion", True)))

    def circle(self, where: str, raw: object) -> FenceCircle:
        obj = self.obj(where, raw)
        inner = self.obj(f"{where}.circle", obj.get("circle"))
        lat, lon = self.coordinate(f"{where}.circle.center", inner.get("center"))
        radius = self.num(f"{where}.circle.radius", inner.get("radius"))
        if radius <= 0:
            raise self.fail(f"{where}.circle.radius", radius, "a radius above 0 m")
        return FenceCircle(lat, lon, radius, bool(obj.get("inclusion", True)))

    def rally_point(self, where: str, raw: object) -> RallyPoint:
        point = self.lst(where, raw)
        lat, lon = self.coordinate(where, point)
        alt = self.num(f"{where}[2]", point[2] if len(point) > 2 else None)
        return RallyPoint(lat, lon, alt)


def read_plan(path: str | Path) -> Plan:
    """Read a QGroundControl ``.plan`` file; ConfigurationError names what is wrong and where."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigurationError("plan", str(path), f"a readable .plan file ({exc})") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigurationError(
            f"{path}: line {exc.lineno}", exc.msg, "a QGroundControl plan (JSON)"
        ) from None
    return _Reader(path).plan(doc)


# -- writing --------------------------------------------------------------------------------


def _json_number(value: float) -> float | int | None:
    if math.isnan(value):
        return None
    # float(): a plan built in Python may carry ints, which have no is_integer() before 3.12
    return int(value) if float(value).is_integer() and abs(value) < 2**53 else value


def _item_json(index: int, item: PlanItem) -> dict[str, Any]:
    params = list(item.params)
    if item.command == CMD_DO_JUMP:
        params[0] = params[0] + 1  # a doJumpId: home is 0
    out: dict[str, Any] = {
        "autoContinue": item.autocontinue,
        "command": item.command,
        "doJumpId": index + 1,
        "frame": item.frame,
        "params": [_json_number(p) for p in params],
        "type": "SimpleItem",
    }
    mode = _QGC_ALTITUDE_MODE.get(item.frame)
    if mode is not None:
        out.update({"AMSLAltAboveTerrain": None, "Altitude": item.alt, "AltitudeMode": mode})
    return out


def write_plan(plan: Plan, path: str | Path) -> None:
    """Write ``plan`` as a QGroundControl ``.plan`` file (what ``read_plan`` reads)."""
    doc = {
        "fileType": "Plan",
        "geoFence": {
            "circles": [
                {
                    "circle": {"center": [c.lat, c.lon], "radius": c.radius},
                    "inclusion": c.inclusion,
                    "version": 1,
                }
                for c in plan.circles
            ],
            "polygons": [
                {"inclusion": p.inclusion, "polygon": [list(v) for v in p.vertices], "version": 1}
                for p in plan.polygons
            ],
            "version": 2,
        },
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": plan.cruise_speed,
            "firmwareType": plan.firmware_type,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": plan.hover_speed,
            "items": [_item_json(i, it) for i, it in enumerate(plan.items)],
            "plannedHomePosition": list(plan.home),
            "vehicleType": plan.vehicle_type,
            "version": 2,
        },
        "rallyPoints": {"points": [[r.lat, r.lon, r.alt] for r in plan.rally], "version": 2},
        "version": 1,
    }
    Path(path).write_text(json.dumps(doc, indent=4) + "\n")
