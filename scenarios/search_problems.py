"""The falsification benchmark: four problems whose violations are rare.

Each :class:`Problem` is a simulate function (``simulate(sample, fidelity, seed)``, the one
callback shape of multicosim), a requirement and a search space; the share of the space that
violates the requirement is small (measured by ``bench/bench_search.py`` with uniform
samples, and stated in the README). The problems use the shipped scenarios through their
public APIs:

* ``rover-lane``: the rover FSA under a GPS spoof (a fix that walks away at a steady rate
  from its onset) at a mission speed must stay in a 6 m lane around its planned path. The
  controller measures distances with GPS: a spoof while it drives makes it turn early or
  late, or stop too far.
* ``rover-turn``: the rover's heading after its turn must stay within 40 degrees of the
  planned one... , steering lock and control rate, compass noise and the
  physics world's timestep and solver iterations (the simulation configuration is part of
  the space).
* ``px4-geofence``: the PX4 mission (three waypoints, 40 m from home, 8 m up) under a GPS
  spoof must keep the vehicle's true position within 76 m of home: the autopilot flies where
  the spoofed fix says it is not.
* ``px4-altitude``: the same mission under a barometer spoof must keep the vehicle at least
  1 m above the ground after take-off: the altitude estimate follows the barometer, until
  the barometer disagrees with GPS by more than 8 m (the estimator then drops it, as PX4's
  EKF2 does). Only a spoof between about 7 and 8 m, during the mission, brings it down.

Every problem runs at low and medium fidelity (MuJoCo physics, realistic sensor noise,
processes in lockstep); the benchmark searches at low and confirms at medium.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

import multicosim as mcs
import multicosim.attacks as attacks
import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim.falsify import Choice, FalsificationResult, Integer, Real, falsify
from multicosim.geo import LocalProjection
from multicosim.requirements import Requirement

__all__ = ["PROBLEMS", "Problem"]


@dataclasses.dataclass(frozen=True)
class Problem:
    """A falsification problem: simulate, requirement, space, and a budget that suits it."""

    name: str
    description: str
    simulate: Any
    requirement: Requirement
    space: Mapping[str, Any]
    budget: int

    def search(self, *, seed: int, levels: Any = ("low",), **options: Any) -> FalsificationResult:
        """Falsify this problem (the problem's budget unless ``budget`` is given)."""
        options.setdefault("budget", self.budget)
        return falsify(
            self.simulate, self.requirement, self.space, seed=seed, levels=levels, **options
        )


# -- the rover ------------------------------------------------------------------------------

LANE = 6.0  # m either side of the planned path
LANE_MISSION = {"wait": 5.0, "distance": 7.0, "final_distance": 7.0}


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
    """Fly the lane mission under the sample's GPS spoof: time and distance to the plan."""
    mission = rover.Mission(speed=sample["speed"], **LANE_MISSION)
    simulator = rover.Rover(fidelity=fidelity, seed=seed)  # type: ignore[arg-type]
    # A spoof that walks the fix away at a steady rate: the controller's sense of distance
    # drifts with it.
    spoof = attacks.Drift(rate=(sample["east"], sample["north"], 0.0), start=sample["start"])
    attacks.inject(simulator, "gps", [spoof])
    truth = _Truth()
    simulator.add(mcs.InProcessComponent(lambda: truth, name="truth"))
    with simulator.start() as simulation:
        simulation.controller.send(mission)
    off = distance_to_path(np.array(truth.points), planned_path(mission))
    return {"time": truth.times, "off_lane": off}


LANE_SPACE: dict[str, Any] = {
    "east": (-0.3, 0.3),  # spoof drift, m/s
    "north": (-0.3, 0.3),
    "start": (0.0, 30.0),  # s after the start of the run
    "speed": (1.0, 5.0),  # m/s
}

TURN_LIMIT = math.radians(9.0)
TURN_MISSION = {"wait": 0.5, "distance": 2.0, "final_distance": 3.0}


def rover_turn(sample: Mapping[str, Any], fidelity: str, seed: int) -> dict[str, Any]:
    """A short turn mission with the sample's mission, sensor and world configuration."""
    mission = rover.Mission(
        speed=sample["speed"], steering=sample["steering"], rate=sample["rate"], **TURN_MISSION
    )
    base = rover.default_noise(fidelity)  # type: ignore[arg-type]
    noise = dataclasses.replace(base, magnetometer=sample["compass_noise"])
    world = dataclasses.replace(
        rover.default_world(fidelity),  # type: ignore[arg-type]
        timestep=sample["timestep"],
        iterations=sample["iterations"],
    )
    with rover.Rover(fidelity=fidelity, seed=seed, world=world, noise=noise).start() as sim:  # type: ignore[arg-type]
        trajectory = sim.controller.send(mission)
    after = [s.state in ("drive_again", "done") for s in trajectory.samples]
    sign = 1.0 if mission.turn_angle > 0 else -1.0
    overshoot = [
        sign * math.remainder(s.heading - mission.turn_angle, math.tau) if a else 0.0
        for s, a in zip(trajectory.samples, after, strict=True)
    ]
    return {"time": trajectory.times, "overshoot": overshoot}


TURN_SPACE: dict[str, Any] = {
    "speed": (1.0, 10.0),  # m/s, also the turn speed
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


# 8 m up: the estimator drops a barometer more than 8 m off, so the floor is within reach
# of the spoofs it still trusts.
ALTITUDE = 8.0
PX4_MISSION = px4.Configuration(
    [_waypoint(0, 40, ALTITUDE), _waypoint(40, 40, ALTITUDE), _waypoint(40, 0, ALTITUDE)],
    end="hold",
    time_limit=120.0,
)


def _fly(models: list[attacks.Model], sensor: str, fidelity: str, seed: int) -> px4.MissionResult:
    simulator = px4.PX4(fidelity=fidelity, seed=seed)  # type: ignore[arg-type]
    attacks.inject(simulator, sensor, models)
    with simulator.start() as simulation:
        return simulation.firmware.send(PX4_MISSION)


def px4_geofence(sample: Mapping[str, Any], fidelity: str, seed: int) -> dict[str, Any]:
    """The mission under the sample's GPS spoof: time and true distance from home."""
    spoof = attacks.Jump(
        offset=(sample["east"], sample["north"], 0.0), start=sample["start"], ramp=sample["ramp"]
    )
    result = _fly([spoof], "gps", fidelity, seed)
    distance = [math.hypot(*PROJECTION.project(s.true_lat, s.true_lon)) for s in result.trajectory]
    return {"time": [s.time for s in result.trajectory], "distance": distance}


def px4_altitude(sample: Mapping[str, Any], fidelity: str, seed: int) -> dict[str, Any]:
    """The mission under the sample's barometer spoof: true height once past take-off."""
    spoof = attacks.Jump(offset=sample["offset"], start=sample["start"], ramp=sample["ramp"])
    result = _fly([spoof], "baro", fidelity, seed)
    # Before the first waypoint is current, the vehicle is on the ground or climbing.
    height = [s.true_alt if s.current >= 1 else FLOOR + 10.0 for s in result.trajectory]
    return {"time": [s.time for s in result.trajectory], "height": height}


SPOOF_SPACE: dict[str, Any] = {
    "east": (-20.0, 20.0),  # spoof offset, m
    "north": (-20.0, 20.0),
    "start": (0.0, 60.0),  # s after the start of the run
    "ramp": (0.0, 10.0),  # s to reach the full offset
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
            "rover turn overshoots by at most 9 degrees, over mission, noise and world",
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
        ),
        Problem(
            "px4-altitude",
            f"PX4 mission under a barometer spoof stays {FLOOR:g} m above ground",
            px4_altitude,
            Requirement(f"always (height >= {FLOOR:g})", name="altitude floor"),
            BARO_SPACE,
            200,
        ),
    )
}
