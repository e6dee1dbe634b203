"""The UAV Testing Competition's test cases (SBFT and ICST): read, written and scored as it does.

The competition's tools (its runner, Aerialist, and the test generators built on it) write a
test case as YAML:

```yaml
drone:
  port: ros                        # where their drone listens: not used here
  params_file: mission-params.csv  # PX4 parameters, "NAME, value" lines (or params: {...})
  mission_file: mission2.plan      # a QGroundControl plan
simulation:
  simulator: ros                   # their simulator, speed, headless: not used here
  obstacles:                       # boxes: size, centre on the ground, rotation
  - size: {l: 10, w: 5, h: 20}
    position: {x: 10, y: 20, z: 0, r: 0}
test:                              # (or mission:)
  commands_file: mission-commands.csv   # timestamp,mode,x,y,z,r; mode 3 starts the mission
```

Their frame is PX4's local one: ``x`` metres north and ``y`` east of where the vehicle
starts, ``z`` 0 (an obstacle stands on the ground, ``h`` tall); the position is the box's
centre, ``l`` lies along ``x`` and ``w`` along ``y`` before the box turns ``r`` degrees from
``x`` towards ``y`` (clockwise from north): our [`Box`][multicosim.physics.Box] with
``north=x, east=y, length=l, width=w, height=h, yaw=r``. A ``shape: cylinder`` has radius
``size.r``. Paths are relative to the folder the tools ran in, which is the case's folder or
one above it: a path is looked for beside the file, then in each folder above it.

Scoring is the competition's: the minimum horizontal distance from the vehicle's estimated
track (a line through its positions, as wide as the vehicle) to each obstacle's footprint;
a collision is a hard fail, a minimum under
[`SAFE_DISTANCE`][multicosim.px4.competition.SAFE_DISTANCE] a soft fail, and each simulation earns
[`POINTS`][multicosim.px4.competition.POINTS] by its minimum. What their commands can do beyond
starting the mission (mode changes at set times, manual setpoints), and their wind and home
position, are refused with the field named: the built-in autopilot and real PX4 fly the plan from
the start.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.deps import require
from ..core.errors import ConfigurationError
from ..core.fields import FieldReader
from ..mavlink.mission import FlightSample
from ..mavlink.params import PARAM_NAME, read_params
from ..physics.config import DEFAULT_HOME
from ..physics.obstacles import Box, Cylinder, Obstacle, Placed, check_obstacles, placed

__all__ = [
    "MISSION_MODE",
    "POINTS",
    "SAFE_DISTANCE",
    "TIMEOUT",
    "VEHICLE_WIDTH",
    "CompetitionCase",
    "Score",
    "distances",
    "read_case",
    "score",
    "write_case",
]

SAFE_DISTANCE = 1.5
"""The competition's safe distance (m): a flight that comes closer to an obstacle soft-fails."""

POINTS = ((0.25, 5), (1.0, 2), (SAFE_DISTANCE, 1))
"""A simulation's points by its minimum distance: under 0.25 m 5, under 1 m 2, under 1.5 m 1,
else 0 (the competition's ``point(sim)``)."""

TIMEOUT = 500.0
"""Seconds of real time the competition's evaluation gives one simulation (Gazebo at speed 1)."""

VEHICLE_WIDTH = 0.25
"""How wide the competition draws the vehicle's track (m): distances are to its edge."""

MISSION_MODE = 3
"""PX4's Mission mode in the competition's commands: arm and fly the plan."""

# PX4's main modes as the competition's commands number them, to name a refused one.
_MODES = {
    0: "Manual",
    1: "Altitude",
    2: "Position",
    3: "Mission",
    4: "Hold",
    5: "Return",
    6: "Acro",
    7: "Offboard",
    8: "Stabilized",
    10: "Takeoff",
    11: "Land",
    12: "FollowMe",
    20: "Arm",
    21: "Disarm",
    100: "Setpoint",
}
_ONLY_MISSION = (
    f"one command, mode {MISSION_MODE} (Mission), which flies the plan from the start; "
    "mode changes at set times and manual setpoints are not flown here"
)
# What each part of a case may hold: the fields read, and those that change nothing here
# (their simulator, its speed and window, where their drone listens, their agents, the
# reference flight they plot beside).
_FIELDS = {
    "drone": ({"params", "params_file", "mission_file"}, {"port", "type"}),
    "simulation": ({"obstacles", "timeout"}, {"simulator", "speed", "headless", "world"}),
    "test": ({"commands", "commands_file"}, {"speed"}),
    "assertion": (set(), {"log_file", "variable"}),
    "agent": (set(), {"engine", "count", "path", "id"}),
}
_ALIASES = {"robot": "drone", "mission": "test"}  # later and earlier versions of the format


@dataclasses.dataclass(frozen=True)
class CompetitionCase:
    """One competition test case: the plan it flies, the parameters set, the obstacles.

    ``params_file`` is the CSV the parameters came from (None: given in the case itself);
    ``timeout`` the simulation's time limit in seconds where the case sets one.
    """

    mission_file: Path
    params: dict[str, float] = dataclasses.field(default_factory=dict)
    params_file: Path | None = None
    obstacles: tuple[Obstacle, ...] = ()
    timeout: float | None = None


class _Reader(FieldReader):
    """Reads one case file, naming the file and the field in every error."""

    def number(self, field: str, value: object, lo: float = -math.inf) -> float:
        number = self.num(field, value)
        if number < lo:
            raise self.fail(field, value, f"a finite number of at least {lo:g}")
        return number

    def file(self, field: str, value: object) -> Path:
        """The file a case names: beside the case, else in a folder above it (where the
        competition's tools ran), else, for an absolute path of another machine, its tail."""
        if not isinstance(value, str) or not value.strip():
            raise self.fail(field, value, "a file name")
        given = Path(value)
        tails = [given] + [Path(*given.parts[i:]) for i in range(1, len(given.parts))]
        for tail in tails:
            if tail.is_absolute():
                if tail.is_file():
                    return tail
                continue
            for folder in (self.path.parent, *self.path.parent.parents):
                if (folder / tail).is_file():
                    # Without "..": the same file reads as the same path however it is named.
                    return Path(os.path.normpath(folder / tail))
        raise self.fail(
            field, value, "a file, beside the case or in a folder above it (where it was written)"
        )

    def parts(self, data: object) -> dict[str, dict[str, Any]]:
        top = self.obj("(top level)", data)
        parts: dict[str, dict[str, Any]] = {}
        for key, value in top.items():
            name = _ALIASES.get(key, key)
            if name not in _FIELDS:
                raise self.fail(key, "...", f"one of {', '.join(sorted(_FIELDS))}")
            part = {} if value is None else self.obj(key, value)
            read, ignored = _FIELDS[name]
            for field in part:
                if field not in read | ignored:
                    known = ", ".join(sorted(read | ignored))
                    raise self.fail(f"{key}.{field}", part[field], f"a field of {key}: {known}")
            parts[name] = part
        for needed in ("drone", "simulation"):
            if needed not in parts:
                raise self.fail(needed, None, f"a '{needed}:' part (a competition case)")
        return parts

    def params(self, drone: dict[str, Any]) -> tuple[dict[str, float], Path | None]:
        if "params" in drone and drone["params"] is not None:
            params = {}
            for name, value in self.obj("drone.params", drone["params"]).items():
                if not isinstance(name, str) or not PARAM_NAME.match(name):
                    raise self.fail("drone.params", name, "PX4 parameter names")
                params[name] = self.number(f"drone.params.{name}", value)
            return params, None
        if drone.get("params_file") is None:
            return {}, None
        source = self.file("drone.params_file", drone["params_file"])
        return read_params(source), source

    def obstacle(self, i: int, entry: object) -> Obstacle:
        where = f"simulation.obstacles[{i}]"
        item = self.obj(where, entry)
        size = self.obj(f"{where}.size", item.get("size"))
        position = self.obj(f"{where}.position", item.get("position"))
        shape = item.get("shape") or "box"
        z = self.number(f"{where}.position.z", position.get("z", 0))
        if z != 0:
            raise self.fail(f"{where}.position.z", z, "0: an obstacle stands on the ground")
        north = self.number(f"{where}.position.x", position.get("x"))
        east = self.number(f"{where}.position.y", position.get("y"))
        height = self.number(f"{where}.size.h", size.get("h"), lo=0.0)
        if shape == "cylinder":
            radius = self.number(f"{where}.size.r", size.get("r"), lo=0.0)
            if not radius or not height:
                raise self.fail(f"{where}.size", size, "a radius r and a height h above 0")
            return Cylinder(north=north, east=east, radius=radius, height=height)
        if shape != "box":
            raise self.fail(f"{where}.shape", shape, "box or cylinder")
        length = self.number(f"{where}.size.l", size.get("l"), lo=0.0)
        width = self.number(f"{where}.size.w", size.get("w"), lo=0.0)
        if not (length and width and height):
            raise self.fail(f"{where}.size", size, "l, w and h above 0")
        yaw = self.number(f"{where}.position.r", position.get("r", 0))
        return Box(north=north, east=east, length=length, width=width, height=height, yaw=yaw)

    def obstacles(self, value: object) -> tuple[Obstacle, ...]:
        if value is None:
            return ()
        if not isinstance(value, list):
            raise self.fail("simulation.obstacles", value, "a list of obstacles")
        if value and not isinstance(value[0], dict):
            # Their flat form: l, w, h, x, y, z, r for each box in turn.
            if len(value) % 7:
                raise self.fail("simulation.obstacles", value, "7 numbers a box: l,w,h,x,y,z,r")
            keys = ("l", "w", "h", "x", "y", "z", "r")
            value = [
                {
                    "size": dict(zip(keys[:3], value[i : i + 3], strict=True)),
                    "position": dict(zip(keys[3:], value[i + 3 : i + 7], strict=True)),
                }
                for i in range(0, len(value), 7)
            ]
        found = tuple(self.obstacle(i, entry) for i, entry in enumerate(value))
        try:
            check_obstacles(found, DEFAULT_HOME)
        except ConfigurationError as exc:
            where = exc.field.replace("obstacles", "simulation.obstacles", 1)
            raise self.fail(where, exc.value, exc.allowed) from None
        return found

    def commands(self, test: dict[str, Any]) -> None:
        """Check that the commands start the mission, as all the flights here do."""
        if test.get("commands") is not None:
            field, rows = "test.commands", test["commands"]
            if not isinstance(rows, list):
                raise self.fail(field, rows, "a list of commands")
        elif test.get("commands_file") is not None:
            source = self.file("test.commands_file", test["commands_file"])
            with source.open(newline="") as file:
                rows = list(csv.DictReader(file))
            field = f"test.commands_file ({source.name})"
        else:
            raise self.fail("test.commands", None, _ONLY_MISSION)
        if len(rows) != 1:
            raise self.fail(field, f"{len(rows)} commands", _ONLY_MISSION)
        command = self.obj(f"{field}[0]", rows[0])
        mode = command.get("mode")
        try:
            number = int(str(mode).strip())
        except ValueError:
            number = -1
        if number != MISSION_MODE:
            shown = f"{mode} ({_MODES[number]})" if number in _MODES else mode
            raise self.fail(f"{field}[0].mode", shown, _ONLY_MISSION)


def read_case(path: str | Path) -> CompetitionCase:
    """Read the competition case in ``path``.

    Raises:
        ConfigurationError: naming the file, the field, its value and what is allowed: a
            missing plan, a box with a size that is not positive or off the ground, obstacles
            that overlap, a command other than the mission's start, a field of the format
            that is not flown here (wind, home position).
    """
    path = Path(path)
    require("yaml", "cases")  # msgspec reads YAML through PyYAML
    import msgspec

    reader = _Reader(path)
    try:
        data = msgspec.yaml.decode(path.read_bytes())
    except (OSError, msgspec.DecodeError) as exc:
        raise reader.fail("(file)", str(path), f"a readable YAML file ({exc})") from None
    parts = reader.parts(data)
    drone, simulation = parts["drone"], parts["simulation"]
    reader.commands(parts.get("test", {}))
    params, params_file = reader.params(drone)
    timeout = simulation.get("timeout")
    # Their timeout of 0 or less means none.
    limit = reader.number("simulation.timeout", timeout) if timeout is not None else 0.0
    return CompetitionCase(
        mission_file=reader.file("drone.mission_file", drone.get("mission_file")),
        params=params,
        params_file=params_file,
        obstacles=reader.obstacles(simulation.get("obstacles")),
        timeout=limit if limit > 0 else None,
    )


def _entry(i: int, obstacle: Obstacle) -> dict[str, Any]:
    if obstacle.north is None or obstacle.east is None:
        raise ConfigurationError(
            f"obstacles[{i}]", obstacle, "north= and east= (the competition places in metres)"
        )
    position = {"x": obstacle.north, "y": obstacle.east, "z": 0}
    if isinstance(obstacle, Cylinder):
        d = 2 * obstacle.radius
        size = {"l": d, "w": d, "h": obstacle.height, "r": obstacle.radius}
        return {"shape": "cylinder", "size": size, "position": {**position, "r": 0}}
    size = {"l": obstacle.length, "w": obstacle.width, "h": obstacle.height}
    return {"size": size, "position": {**position, "r": obstacle.yaw}}


def write_case(case: CompetitionCase, path: str | Path) -> None:
    """Write ``case`` as a competition case YAML file (paths relative to its folder)."""
    require("yaml", "cases")
    import msgspec

    path = Path(path)

    def relative(file: Path) -> str:
        return os.path.relpath(file.absolute(), path.parent.absolute())

    drone: dict[str, Any] = {"port": "sitl", "mission_file": relative(case.mission_file)}
    if case.params_file is not None:
        drone["params_file"] = relative(case.params_file)
    elif case.params:
        drone["params"] = dict(case.params)
    simulation: dict[str, Any] = {"simulator": "gazebo", "speed": 1, "headless": True}
    if case.obstacles:
        simulation["obstacles"] = [_entry(i, o) for i, o in enumerate(case.obstacles)]
    if case.timeout is not None:
        simulation["timeout"] = case.timeout
    start = {"timestamp": 1, "mode": MISSION_MODE, "x": 0, "y": 0, "z": 0.5, "r": 0}
    data = {"drone": drone, "simulation": simulation, "test": {"commands": [start]}}
    path.write_bytes(msgspec.yaml.encode(data))


# -- scoring ------------------------------------------------------------------------------


def _to_segment(n: float, e: float, a: tuple[float, float], b: tuple[float, float]) -> float:
    """Distance (m) from the point ``n``/``e`` to the segment from ``a`` to ``b``."""
    dn, de = b[0] - a[0], b[1] - a[1]
    span = dn * dn + de * de
    t = 0.0 if span == 0 else max(0.0, min(1.0, ((n - a[0]) * dn + (e - a[1]) * de) / span))
    return math.hypot(n - a[0] - t * dn, e - a[1] - t * de)


def _side(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float]) -> float:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _cross(
    a: tuple[float, float], b: tuple[float, float], c: tuple[float, float], d: tuple[float, float]
) -> bool:
    """Whether segments a-b and c-d meet (touching counts)."""
    d1, d2, d3, d4 = _side(c, d, a), _side(c, d, b), _side(a, b, c), _side(a, b, d)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True
    # Collinear or touching: an end on the other segment.
    return any(
        _to_segment(*p, *seg) == 0.0
        for p, seg in ((a, (c, d)), (b, (c, d)), (c, (a, b)), (d, (a, b)))
    )


def _gap(p: Placed, a: tuple[float, float], b: tuple[float, float]) -> float:
    """Horizontal distance (m) from the segment ``a``-``b`` to a footprint (0: they meet)."""
    if p.radius:
        return max(0.0, _to_segment(p.north, p.east, a, b) - p.radius)
    ends = min(p.footprint_distance(*a), p.footprint_distance(*b))
    if ends <= 0.0:
        return 0.0
    corners = p.corners()
    if any(_cross(a, b, c, d) for c, d in zip(corners, corners[1:] + corners[:1], strict=True)):
        return 0.0
    # A convex footprint and a segment apart: the nearest pair has an end or a corner in it.
    return min(ends, *(_to_segment(n, e, a, b) for n, e in corners))


def distances(
    trajectory: Sequence[FlightSample],
    obstacles: Sequence[Obstacle],
    home: tuple[float, float, float] = DEFAULT_HOME,
) -> list[float]:
    """The competition's distance from the flight to each obstacle (m), in their order.

    The vehicle's estimated positions (``north``/``east``, as the competition reads PX4's
    local position) make a line as wide as
    [`VEHICLE_WIDTH`][multicosim.px4.competition.VEHICLE_WIDTH]; the distance is the horizontal one
    from that line to the obstacle's footprint, 0 where they meet (flying over an obstacle counts as
    meeting it, as in the competition).
    """
    track = [(s.north, s.east) for s in trajectory]
    if len(track) == 1:
        track *= 2
    out = []
    for p in placed(obstacles, home):
        nearest = min((_gap(p, a, b) for a, b in itertools.pairwise(track)), default=math.inf)
        out.append(max(0.0, nearest - VEHICLE_WIDTH / 2))
    return out


@dataclasses.dataclass(frozen=True)
class Score:
    """A flight scored as the competition scores it.

    ``distances`` per obstacle (m, in the case's order); ``collided`` whether the vehicle hit
    one (in our world: its physics or, at low fidelity, its geometry).
    """

    distances: tuple[float, ...]
    collided: bool

    @property
    def min_distance(self) -> float:
        """The competition's ``min_dist`` (m): infinite without obstacles."""
        return min(self.distances, default=math.inf)

    @property
    def point(self) -> int:
        """The simulation's points: 5, 2, 1 or 0 by
        [`POINTS`][multicosim.px4.competition.POINTS]."""
        return next((p for limit, p in POINTS if self.min_distance < limit), 0)

    @property
    def verdict(self) -> str:
        """``hard fail`` (a collision), ``soft fail`` (closer than 1.5 m) or ``pass``."""
        if self.collided:
            return "hard fail"
        return "soft fail" if self.min_distance < SAFE_DISTANCE else "pass"


def score(
    trajectory: Sequence[FlightSample],
    obstacles: Sequence[Obstacle],
    collided: bool,
    home: tuple[float, float, float] = DEFAULT_HOME,
) -> Score:
    """Score a flight among ``obstacles`` as the competition does (see
    [`Score`][multicosim.px4.competition.Score])."""
    return Score(tuple(distances(trajectory, obstacles, home)), collided)
