"""The falsification benchmark: six problems whose violations are rare.

Each :class:`Problem` is a simulate function (``simulate(sample, fidelity, seed)``, the one
callback shape of multicosim), a requirement and a search space; the share of the space that
violates the requirement is small (measured by ``bench/bench_search.py`` with uniform
samples, and stated in docs/benchmarks.md). The problems use the shipped scenarios through their
public APIs:

* ``rover-lane``: the rover FSA under a GPS spoof (an offset that appears at its onset,
  reached over a ramp) at a mission speed must stay in a 6 m lane around its planned path.
  The controller measures distances with GPS: a spoof while it drives makes it turn late, or
  drive on past its end point.
* ``rover-turn``: the rover's true heading must never go more than 20 degrees past the
  planned one, under a compass spoof (a heading that walks away at a steady rate for a
  while), over the mission's speed, steering lock and control rate, the compass's noise and
  the physics world's timestep and solver iterations (the simulation configuration is part
  of the space): the controller counts its turn on the compass, so a spoof during a long,
  slow turn makes it turn too far.
* ``px4-geofence``: the PX4 mission (three waypoints, 40 m from home, 8 m up) under a GPS
  spoof must keep the vehicle's true position within 76 m of home: the autopilot flies where
  the spoofed fix says it is not.
* ``px4-altitude``: the same mission, flown on barometric height (``EKF2_HGT_REF`` 0; with
  PX4's default, GNSS height, a barometer spoof barely moves the estimate), under a
  barometer spoof must keep the vehicle at least 1 m above the ground after take-off: the
  altitude estimate follows the barometer, until the barometer disagrees with GPS by more
  than 8 m (the estimator then drops it): a spoof brings it down only if it reaches 7 m and
  is not more than 8 m for long (a narrow band, or a slow ramp through it), during the
  mission.
* ``px4-separation``: two PX4 quadrotors flying to each other's start on parallel lines 8 m
  apart, 10 m up, in the sample's wind, with a GPS spoof on ``bravo``, must keep 2 m apart:
  the spoof moves ``bravo`` onto ``alpha``'s line only if it is about 8 m eastwards and
  comes before the two meet (a steady offset: the GPS says east, the vehicle goes west).

Every problem runs at low and medium fidelity (MuJoCo physics, realistic sensor noise,
processes in lockstep); the benchmark searches at low and confirms at medium. The rover
problems give every level the same realistic sensor noise: with ideal sensors at low
fidelity, a violation can rest on a balance that a centimetre of GPS noise breaks (the
controller creeping towards its end point exactly as fast as a spoof walks the fix away),
and would not transfer. The PX4 problems also fly real PX4 SITL: :meth:`Problem.levels`
with a :class:`multicosim.px4.SITL` adds it as the top level (search at low, confirm at
medium, confirm on real PX4).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

import multicosim as mcs
import multicosim.attacks as attacks
import multicosim.fleet as fleet
import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim.core.geo import LocalProjection
from multicosim.physics import Cylinder, Pose, Wind
from multicosim.px4.scenario import default_world
from multicosim.search.falsify import Choice, FalsificationResult, Integer, Level, Real, falsify
from multicosim.search.requirements import Requirement

__all__ = ["PROBLEMS", "Problem"]


@dataclasses.dataclass(frozen=True)
class Problem:
    """A falsification problem: simulate, requirement, space, and a budget that suits it.

    ``flies_px4``: ``simulate`` takes a ``firmware`` keyword (a :class:`px4.SITL` flies the
    mission on real PX4).
    """

    name: str
    description: str
    simulate: Any
    requirement: Requirement
    space: Mapping[str, Any]
    budget: int
    flies_px4: bool = False

    def levels(self, firmware: px4.SITL | None = None) -> tuple[str | Level, ...]:
        """Search at low, confirm at medium, and on real PX4 where ``firmware`` is given
        (PX4 problems only: the rover has no real firmware to confirm on)."""
        if firmware is None or not self.flies_px4:
            return ("low", "medium")
        return ("low", "medium", px4.sitl_level(self.simulate, firmware))

    def search(self, *, seed: int, levels: Any = ("low",), **options: Any) -> FalsificationResult:
        """Falsify this problem (the problem's budget unless ``budget`` is given)."""
        options.setdefault("budget", self.budget)
        return falsify(
            self.simulate, self.requirement, self.space, seed=seed, levels=levels, **options
        )


# -- the rover ------------------------------------------------------------------------------

LANE = 6.0  # m either side of the planned path
LANE_MISSION = {"wait": 5.0, "distance": 7.0, "final_distance": 7.0}
# The same realistic sensors at every level (see the module's docstring).
NOISE = rover.SensorNoise.realistic()


class _Truth:
    """A participant that keeps the rover's true position (the world's raw GPS topic)."""

    period = 0.05

    def __init__(self) -> None:
        self.times: list[float] = []
        self.points: list[tuple[float, float]] = []

    def setup(self, ctx: mcs.StepContext) -> None:
        self.position = ctx.subscribe(f"{rover.SENSOR_TOPICS['position']}/raw", rover.Position)

    def step(self, ctx: mcs.StepContext) -> None:
        p = self.position.latest
        if p is not None:
            self.times.append(ctx.time)
            self.points.append((p.x, p.y))


def planned_path(mission: rover.Mission, arc_points: int = 90) -> np.ndarray:
    """The planned path as a polyline: straight, the arc of the steering lock, straight."""
    radius = rover.WHEELBASE / math.tan(mission.steering)
    sign = 1.0 if mission.turn_angle > 0 else -1.0
    points = [(0.0, 0.0), (mission.distance, 0.0)]
    for k in range(1, arc_points + 1):
        a = abs(mission.turn_angle) * k / arc_points
        points.append((mission.distance + radius * math.sin(a), sign * radius * (1 - math.cos(a))))
    heading = mission.turn_angle
    x, y = points[-1]
    points.append(
        (
            x + mission.final_distance * math.cos(heading),
            y + mission.final_distance * math.sin(heading),
        )
    )
    return np.array(points)


def distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Each point's distance to the polyline ``path``."""
    a, b = path[:-1], path[1:]
    ab = b - a
    ap = points[:, None, :] - a[None, :, :]
    t = np.clip((ap * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]
    distances: np.ndarray = np.sqrt(((points[:, None, :] - nearest) ** 2).sum(-1)).min(axis=1)
    return distances


def rover_lane(sample: Mapping[str, Any], fidelity: str, seed: int) -> dict[str, Any]:
    """Drive the lane mission under the sample's GPS spoof: time and distance to the plan."""
    mission = rover.Mission(speed=sample["speed"], **LANE_MISSION)
    simulator = rover.Rover(fidelity=fidelity, seed=seed, noise=NOISE)  # type: ignore[arg-type]
    spoof = attacks.Jump(
        offset=attacks.Local(east=sample["east"], north=sample["north"]),
        start=sample["start"],
        ramp=sample["ramp"],
    )
    attacks.inject(simulator, "gps", [spoof])
    truth = _Truth()
    simulator.add(mcs.InProcessComponent(lambda: truth, name="truth"))
    with simulator.start() as simulation:
        simulation.controller.send(mission)
    off = distance_to_path(np.array(truth.points), planned_path(mission))
    return {"time": truth.times, "off_lane": off}


LANE_SPACE: dict[str, Any] = {
    "east": (-8.0, 8.0),  # spoof offset, m
    "north": (-8.0, 8.0),
    "start": (0.0, 30.0),  # s after the start of the run
    "ramp": (0.0, 10.0),  # s to reach the full offset
    "speed": (1.0, 5.0),  # m/s
}

TURN_LIMIT = math.radians(20.0)
TURN_MISSION = {"wait": 0.5, "distance": 2.0, "final_distance": 3.0}


class _Yaw:
    """A participant that keeps the rover's true heading (the IMU's orientation)."""

    period = 0.05

    def __init__(self) -> None:
        self.times: list[float] = []
        self.yaw: list[float] = []

    def setup(self, ctx: mcs.StepContext) -> None:
        self.imu = ctx.subscribe(rover.SENSOR_TOPICS["imu"], rover.Imu)

    def step(self, ctx: mcs.StepContext) -> None:
        latest = self.imu.latest
        if latest is not None:
            self.times.append(ctx.time)
            self.yaw.append(rover.yaw_from_quaternion(latest.orientation))


def rover_turn(sample: Mapping[str, Any], fidelity: str, seed: int) -> dict[str, Any]:
    """A turn under the sample's compass spoof, mission, sensor and world configuration: how
    far the true heading goes past the planned one (negative until the turn is done)."""
    mission = rover.Mission(
        speed=sample["speed"], steering=sample["steering"], rate=sample["rate"], **TURN_MISSION
    )
    world = dataclasses.replace(
        rover.default_world(fidelity),  # type: ignore[arg-type]
        timestep=sample["timestep"],
        iterations=sample["iterations"],
    )
    noise = dataclasses.replace(NOISE, magnetometer=sample["compass_noise"])
    simulator = rover.Rover(fidelity=fidelity, seed=seed, world=world, noise=noise)  # type: ignore[arg-type]
    # The heading the compass gives walks away at a steady rate for a while, then snaps back:
    # the controller, which counts its turn on the compass, turns too far (or not far enough).
    end = sample["start"] + sample["duration"]
    spoof = attacks.Drift(rate=sample["drift"], start=sample["start"], end=end)
    attacks.inject(simulator, "magnetometer", [spoof])
    truth = _Yaw()
    simulator.add(mcs.InProcessComponent(lambda: truth, name="truth"))
    with simulator.start() as simulation:
        simulation.controller.send(mission)
    # Over the whole run, not only once the controller says the turn is done: a turn the
    # spoof keeps going (until it times out) is the worst overshoot, and the margin then
    # shrinks steadily towards it instead of jumping back to the limit.
    sign = 1.0 if mission.turn_angle > 0 else -1.0
    overshoot = [sign * math.remainder(yaw - mission.turn_angle, math.tau) for yaw in truth.yaw]
    return {"time": truth.times, "overshoot": overshoot}


TURN_SPACE: dict[str, Any] = {
    "drift": (-0.15, 0.15),  # rad/s, how fast the compass spoof walks the heading away
    "start": (0.0, 10.0),  # s after the start of the run
    "duration": (0.5, 10.0),  # s until the spoof stops
    "speed": (1.0, 5.0),  # m/s, also the turn speed
    "steering": (0.1, 0.5),  # rad, the steering lock of the turn
    "rate": (10.0, 40.0),  # Hz, the controller's loop
    "compass_noise": (0.0, 4e-7),  # T, the magnetometer's noise (the field is 2e-5 T)
    "timestep": Choice(0.0005, 0.001, 0.0025),  # s, MuJoCo's step (medium and high)
    "iterations": Integer(5, 100),  # the constraint solver's iterations
}

# -- PX4 ------------------------------------------------------------------------------------

HOME = px4.Home()
PROJECTION = LocalProjection(HOME.lat, HOME.lon)
FENCE = 76.0  # m from home
FLOOR = 1.0  # m above home after take-off


def _waypoint(north: float, east: float, alt: float) -> px4.Waypoint:
    lat, lon = PROJECTION.reproject(north, east)
    return px4.Waypoint(lat, lon, alt)


# Height from the barometer (PX4's EKF2_HGT_REF 0), not PX4's default GNSS.
BARO_HEIGHT = {"EKF2_HGT_REF": 0.0}
# 8 m up: the estimator drops a barometer more than 8 m off, so the floor is within reach
# of the spoofs it still trusts.
ALTITUDE = 8.0
PX4_MISSION = px4.Configuration(
    [_waypoint(0, 40, ALTITUDE), _waypoint(40, 40, ALTITUDE), _waypoint(40, 0, ALTITUDE)],
    end="hold",
    time_limit=120.0,
)


def _fly(
    models: list[attacks.Model],
    sensor: str,
    fidelity: str,
    seed: int,
    firmware: px4.SITL | None,
    params: dict[str, float] | None = None,
) -> px4.MissionResult:
    simulator = px4.PX4(fidelity=fidelity, seed=seed, firmware=firmware, params=params or {})  # type: ignore[arg-type]
    attacks.inject(simulator, sensor, models)
    with simulator.start() as simulation:
        return simulation.firmware.send(PX4_MISSION)


def px4_geofence(
    sample: Mapping[str, Any], fidelity: str, seed: int, firmware: px4.SITL | None = None
) -> dict[str, Any]:
    """The mission under the sample's GPS spoof: time and true distance from home.

    ``firmware``: real PX4 SITL flies it (medium or high fidelity) instead of the built-in
    autopilot."""
    spoof = attacks.Jump(
        offset=attacks.Local(east=sample["east"], north=sample["north"]),
        start=sample["start"],
        ramp=sample["ramp"],
    )
    result = _fly([spoof], "gps", fidelity, seed, firmware)
    distance = [math.hypot(*PROJECTION.project(s.true_lat, s.true_lon)) for s in result.trajectory]
    return {"time": [s.time for s in result.trajectory], "distance": distance}


def px4_altitude(
    sample: Mapping[str, Any], fidelity: str, seed: int, firmware: px4.SITL | None = None
) -> dict[str, Any]:
    """The mission under the sample's barometer spoof: true height once past take-off
    (``firmware`` as for :func:`px4_geofence`)."""
    spoof = attacks.Jump(offset=sample["offset"], start=sample["start"], ramp=sample["ramp"])
    result = _fly([spoof], "baro", fidelity, seed, firmware, BARO_HEIGHT)
    # Before the first waypoint is current, the vehicle is on the ground or climbing.
    height = [s.true_alt if s.current >= 1 else FLOOR + 10.0 for s in result.trajectory]
    return {"time": [s.time for s in result.trajectory], "height": height}


# A mission with one corner: north 60 m, then east 40 m, 10 m up.
CORNER_PATH = ((0.0, 0.0), (60.0, 0.0), (60.0, 40.0))
CORNER_MISSION = px4.Configuration(
    [_waypoint(n, e, 10.0) for n, e in CORNER_PATH[1:]], end="hold", time_limit=90.0
)
CLEARANCE = 1.5  # m: the community benchmark's soft limit
OFF_PATH = 2.0  # m: no obstacle's surface comes nearer the planned path than this


def _nearest_on_path(north: float, east: float) -> tuple[float, float]:
    """The point of the planned path (a polyline) nearest ``north, east``."""
    best = (math.inf, 0.0, 0.0)
    for (n0, e0), (n1, e1) in itertools.pairwise(CORNER_PATH):
        dn, de = n1 - n0, e1 - e0
        t = min(1.0, max(0.0, ((north - n0) * dn + (east - e0) * de) / (dn * dn + de * de)))
        qn, qe = n0 + t * dn, e0 + t * de
        best = min(best, (math.hypot(north - qn, east - qe), qn, qe))
    return best[1], best[2]


def place_off_path(north: float, east: float, radius: float) -> tuple[float, float]:
    """Where an obstacle of ``radius`` meant for ``north, east`` stands: pushed straight away
    from the planned path until its surface is :data:`OFF_PATH` from it (twice: inside the
    corner, moving away from one leg can bring it near the other)."""
    for _ in range(2):
        qn, qe = _nearest_on_path(north, east)
        d = math.hypot(north - qn, east - qe)
        if d >= OFF_PATH + radius - 1e-9:
            continue
        # On the path itself: to its left (west of the first leg, north of the second).
        un, ue = ((north - qn) / d, (east - qe) / d) if d > 1e-9 else (0.0, -1.0)
        north, east = qn + un * (OFF_PATH + radius), qe + ue * (OFF_PATH + radius)
    return north, east


def px4_clearance(
    sample: Mapping[str, Any], fidelity: str, seed: int, firmware: px4.SITL | None = None
) -> dict[str, Any]:
    """The corner mission past the sample's tower, in the sample's wind: time and the true
    3-D clearance from the vehicle to the tower (``firmware`` as for :func:`px4_geofence`)."""
    north, east = place_off_path(sample["north"], sample["east"], sample["radius"])
    tower = Cylinder(north=north, east=east, radius=sample["radius"], height=30.0, name="tower")
    wind = Wind(
        speed=sample["wind"], direction=sample["direction"], turbulence=sample["turbulence"]
    )
    world = dataclasses.replace(default_world(fidelity), obstacles=(tower,), wind=wind)  # type: ignore[arg-type]
    simulator = px4.PX4(world, fidelity=fidelity, seed=seed, firmware=firmware)  # type: ignore[arg-type]
    with simulator.start() as simulation:
        result = simulation.firmware.send(CORNER_MISSION)
    return {
        "time": [s.time for s in result.trajectory],
        "clearance": [s.clearance for s in result.trajectory],
    }


# Two aircraft that meet: alpha north along east = 0, bravo south along east = 8 m, both 10 m
# up, each to where the other started; wherever they meet (whenever each took off), 8 m apart.
SEPARATION = 2.0  # m between the bodies
MEETING = {
    "alpha": px4.Configuration([_waypoint(60, 0, 10.0)], end="hold", time_limit=90.0),
    "bravo": px4.Configuration([_waypoint(0, 8, 10.0)], end="hold", time_limit=90.0),
}
MEETING_STARTS = {"alpha": Pose(), "bravo": Pose(north=60.0, east=8.0)}


def px4_separation(
    sample: Mapping[str, Any], fidelity: str, seed: int, firmware: px4.SITL | None = None
) -> dict[str, Any]:
    """Both missions at once, in the sample's wind, with the sample's GPS spoof on bravo:
    time and the separation of the two bodies (``firmware``: real PX4 flies both, as for
    :func:`px4_geofence`)."""
    wind = Wind(speed=sample["wind"], direction=sample["direction"])
    world = dataclasses.replace(default_world(fidelity), wind=wind)  # type: ignore[arg-type]
    simulator = fleet.Fleet(
        {
            name: fleet.PX4Vehicle(start=start, firmware=firmware)
            for name, start in MEETING_STARTS.items()
        },
        fidelity=fidelity,  # type: ignore[arg-type]
        seed=seed,
        world=world,
    )
    spoof = attacks.Jump(
        offset=attacks.Local(east=sample["east"], north=sample["north"]),
        start=sample["start"],
        ramp=sample["ramp"],
    )
    attacks.inject(simulator, "bravo/gps", [spoof])
    with simulator.start() as simulation:
        result = simulation.fly(MEETING)
    signals = result.encounter.signals()
    return {"time": signals["time"], "separation": signals["separation"]}


CLEARANCE_SPACE: dict[str, Any] = {
    "north": (-10.0, 75.0),  # m: where the tower is meant to stand (moved off the path)
    "east": (-15.0, 50.0),
    "radius": (0.5, 3.0),  # m
    "wind": (0.0, 12.0),  # m/s, steady
    "direction": (0.0, 360.0),  # degrees clockwise from north, where it blows from
    "turbulence": (0.0, 15.0),  # m/s, Dryden W20 (7.7: light, 15.4: moderate)
}

SPOOF_SPACE: dict[str, Any] = {
    "east": (-20.0, 20.0),  # spoof offset, m
    "north": (-20.0, 20.0),
    "start": (0.0, 60.0),  # s after the start of the run
    "ramp": (0.0, 10.0),  # s to reach the full offset
}
SEPARATION_SPACE: dict[str, Any] = {
    **SPOOF_SPACE,  # bravo's GPS spoof
    "wind": (0.0, 8.0),  # m/s, steady
    "direction": (0.0, 360.0),  # degrees clockwise from north, where it blows from
}

BARO_SPACE: dict[str, Any] = {
    "offset": (-10.0, 10.0),  # m added to the barometric altitude
    "start": (0.0, 60.0),
    "ramp": Real(0.0, 10.0),
}

PROBLEMS: dict[str, Problem] = {
    p.name: p
    for p in (
        Problem(
            "rover-lane",
            "rover FSA under a GPS spoof stays within 6 m of its planned path",
            rover_lane,
            Requirement(f"always (off_lane <= {LANE:g})", name="rover stays in its lane"),
            LANE_SPACE,
            200,
        ),
        Problem(
            "rover-turn",
            "rover turn under a compass spoof overshoots by at most 20 degrees, over mission, "
            "noise and world",
            rover_turn,
            Requirement(f"always (overshoot <= {TURN_LIMIT:.6f})", name="turn overshoot"),
            TURN_SPACE,
            200,
        ),
        Problem(
            "px4-geofence",
            f"PX4 mission under a GPS spoof keeps within {FENCE:g} m of home",
            px4_geofence,
            Requirement(f"always (distance <= {FENCE:g})", name="geofence"),
            SPOOF_SPACE,
            200,
            flies_px4=True,
        ),
        Problem(
            "px4-altitude",
            f"PX4 mission on barometric height under a barometer spoof stays {FLOOR:g} m "
            "above ground",
            px4_altitude,
            Requirement(f"always (height >= {FLOOR:g})", name="altitude floor"),
            BARO_SPACE,
            200,
            flies_px4=True,
        ),
        Problem(
            "px4-clearance",
            f"PX4 mission past a tower (never on its path) in wind keeps {CLEARANCE:g} m clear",
            px4_clearance,
            Requirement(f"always (clearance >= {CLEARANCE:g})", name="clearance"),
            CLEARANCE_SPACE,
            200,
            flies_px4=True,
        ),
        Problem(
            "px4-separation",
            f"two PX4 missions planned to pass 8 m apart, one under a GPS spoof, in wind, keep "
            f"{SEPARATION:g} m apart",
            px4_separation,
            Requirement(f"always (separation >= {SEPARATION:g})", name="separation"),
            SEPARATION_SPACE,
            200,
            flies_px4=True,
        ),
    )
}
