"""PX4 v1.15's mission items, flown as PX4 flies them: a landing at a position of its own as
a mission's only leg, a takeoff with a position, a delay, a speed change, loiter to altitude,
home set mid-mission and the return to it, each on the built-in autopilot and on real PX4 in
our world, held to the same checks. (Which items PX4 takes at all: the conformance test.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.dialect import FRAME_GLOBAL_REL_INT, FRAME_MISSION
from multicosim.mavlink.plan import Plan, PlanItem, write_plan
from multicosim.physics import Box
from multicosim.px4 import conformance
from multicosim.px4.conformance_items import item_key
from multicosim.px4.items import ITEMS, ROI_COMMANDS, table
from pytest_multicosim.px4 import RealPX4

DATA = Path(__file__).parent.parent / "data"
LAND_AWAY = DATA / "land_away.plan"
"""A takeoff to 10 m, then a landing 50 m north: no waypoint at all (QGroundControl's layout,
as the UAV test-generation competition's cases are written)."""
HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
LAND_AT = (50.0, 0.0)  # north, east (m) of the plan's land item
TAKEOFF_EAST = 30.0  # m east of home: where the edited plan's takeoff item lies
ACCEPTANCE = 2.0  # NAV_ACC_RAD in both autopilots' SITL set-up


def takeoff_away(tmp_path: Path) -> Path:
    """The plan with its takeoff item placed :data:`TAKEOFF_EAST` m east of home."""
    doc = json.loads(LAND_AWAY.read_text())
    lat, lon = PROJ.reproject(0.0, TAKEOFF_EAST)
    doc["mission"]["items"][0]["params"][4:6] = [lat, lon]
    path = tmp_path / "takeoff_away.plan"
    path.write_text(json.dumps(doc))
    return path


def track(result: px4.MissionResult) -> list[tuple[float, float, float]]:
    """The true path flown: north, east (m from home), altitude above home (m)."""
    out = []
    for s in result.trajectory:
        n, e = PROJ.project(s.true_lat, s.true_lon)
        out.append((n, e, s.alt))
    return out


def check_landed_at_its_land_item(result: px4.MissionResult) -> None:
    assert result.completed, result.reason
    assert result.landed
    assert not result.armed
    n, e, _ = track(result)[-1]
    assert math.hypot(n - LAND_AT[0], e - LAND_AT[1]) < ACCEPTANCE


def check_took_off_then_flew_to_the_takeoff_item(result: px4.MissionResult) -> None:
    path = track(result)
    # Straight up where it stood, then at the takeoff altitude to the item's own position...
    assert max(abs(e) for n, e, alt in path if alt < 9.0 and n < 1.0) < 1.0
    assert max(e for _, e, _ in path) > TAKEOFF_EAST - ACCEPTANCE - 0.5
    # ...and only then on to the landing.
    first_there = next(i for i, (_, e, _) in enumerate(path) if e > TAKEOFF_EAST - 3.0)
    assert max(n for n, _, _ in path[:first_there]) < 1.0


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_builtin_autopilot_flies_a_takeoff_then_a_landing_elsewhere(fidelity: str) -> None:
    config = px4.Configuration.from_plan(LAND_AWAY)
    assert config.end == "land"
    assert [(round(w.alt, 6)) for w in config.mission] == [0.0]  # the landing's position
    with px4.PX4(fidelity=fidelity).start() as sim:  # type: ignore[arg-type]
        result = sim.firmware.send(config)
    check_landed_at_its_land_item(result)
    assert [r.index for r in result.reached] == [0]
    # It flew the leg at its takeoff altitude, and came down only at the end.
    assert max(alt for n, _, alt in track(result) if 10.0 < n < 40.0) > 9.0
    assert min(alt for n, _, alt in track(result) if 10.0 < n < 40.0) > 9.0


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_builtin_autopilot_flies_to_a_takeoff_items_own_position(
    fidelity: str, tmp_path: Path
) -> None:
    config = px4.Configuration.from_plan(takeoff_away(tmp_path))
    with px4.PX4(fidelity=fidelity).start() as sim:  # type: ignore[arg-type]
        result = sim.firmware.send(config)
    check_landed_at_its_land_item(result)
    check_took_off_then_flew_to_the_takeoff_item(result)


def test_real_px4_flies_a_takeoff_with_a_position_then_a_landing_elsewhere(
    px4_sitl: RealPX4, tmp_path: Path
) -> None:
    # Both at once on one real PX4 start-up each: what the built-in is held to above.
    for plan, takeoff_placed in ((LAND_AWAY, False), (takeoff_away(tmp_path), True)):
        config = px4.Configuration.from_plan(plan)
        simulator = px4.PX4(fidelity="medium", firmware=px4_sitl.sitl())
        with simulator.start() as simulation:
            result = simulation.firmware.send(config)
        check_landed_at_its_land_item(result)
        if takeoff_placed:
            check_took_off_then_flew_to_the_takeoff_item(result)
        else:
            assert max(abs(e) for _, e, _ in track(result)) < 1.0


def items_plan(tmp_path: Path) -> Path:
    """Takeoff; a waypoint 20 m north; a 5 s delay; 2 m/s from there; loiter-to-altitude 15 m
    at 40 m north; home set where the vehicle then is; return to launch."""
    rel, nan = 3, math.nan
    at = PROJ.reproject
    items = [
        PlanItem(22, rel, (0.0, 0.0, 0.0, nan, HOME.lat, HOME.lon, 10.0)),
        PlanItem(16, rel, (0.0, 0.0, 0.0, nan, *at(20.0, 0.0), 10.0)),
        PlanItem(93, 2, (5.0, -1.0, -1.0, -1.0, 0.0, 0.0, 0.0)),
        PlanItem(178, 2, (1.0, 2.0, -1.0, 0.0, 0.0, 0.0, 0.0)),
        PlanItem(31, rel, (0.0, 0.0, 0.0, 0.0, *at(40.0, 0.0), 15.0)),
        PlanItem(179, 2, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
        PlanItem(20, 2, (0.0,) * 7),
    ]
    path = tmp_path / "items.plan"
    write_plan(Plan(items=items, home=(HOME.lat, HOME.lon, HOME.alt), hover_speed=5.0), path)
    return path


def check_items_flown(result: px4.MissionResult) -> None:
    """:func:`items_plan` flown as PX4 flies it."""
    assert result.completed, result.reason
    path = track(result)
    # The delay: held at the first waypoint (flown back to after braking past it) for 5 s.
    delay = [s for s in result.trajectory if s.current == 2]
    assert delay[-1].time - delay[0].time >= 5.0 - 0.5
    assert (
        max(
            abs(n - 20.0)
            for (n, _, _), s in zip(path, result.trajectory, strict=True)
            if s.current == 2
        )
        < 7.0
    )
    assert abs(path[result.trajectory.index(delay[-1])][0] - 20.0) < ACCEPTANCE
    # 2 m/s on the way to the loiter-to-altitude item, which it reaches at 15 m.
    leg = [s for s, (n, _, _) in zip(result.trajectory, path, strict=True) if 25.0 < n < 35.0]
    assert max(math.hypot(s.vx, s.vy) for s in leg) < 2.5
    assert max(alt for _, _, alt in path) > 14.0
    # Home moved to where the vehicle was on reaching it (within its acceptance radius):
    # the return lands there, not where it took off.
    n, e, _ = path[-1]
    assert math.hypot(n - 40.0, e) < 2 * ACCEPTANCE
    assert result.landed


def test_the_builtin_autopilot_flies_delay_speed_loiter_to_altitude_and_set_home(
    tmp_path: Path,
) -> None:
    config = px4.Configuration.from_plan(items_plan(tmp_path))
    with px4.PX4(fidelity="low").start() as sim:
        result = sim.firmware.send(config)
    check_items_flown(result)


def test_real_px4_flies_delay_speed_loiter_to_altitude_and_set_home(
    px4_sitl: RealPX4, tmp_path: Path
) -> None:
    config = px4.Configuration.from_plan(items_plan(tmp_path))
    with px4.PX4(fidelity="medium", firmware=px4_sitl.sitl()).start() as simulation:
        result = simulation.firmware.send(config)
    check_items_flown(result)


def test_every_item_in_the_table_is_one_real_px4_took() -> None:
    answers = conformance.load()["mission items"]
    for command, item in ITEMS.items():
        asked = [f for f in item.frames if command not in ROI_COMMANDS or f == "global"]
        for frame in asked:
            key = item_key(command, FRAME_MISSION if frame == "mission" else FRAME_GLOBAL_REL_INT)
            assert answers[key] == 0, key
    refused = [k for k, ack in answers.items() if ack != 0]
    assert "NAV_LOITER_TURNS (global)" in refused  # what PX4 v1.15 does not fly


def test_the_px4_guide_lists_every_item_as_the_table_has_it() -> None:
    guide = Path(__file__).parent.parent.parent / "docs" / "guides" / "px4.md"
    assert table() in guide.read_text()


RETURN_BOX = Box(north=30.0, east=5.0, length=4.0, width=4.0, height=40.0, name="box")
"""A tall box beside the first leg of :func:`return_mission`, 3 m east of it."""


def return_mission() -> px4.Configuration:
    """60 m north, then 20 m east, then return to launch (a new user's plan)."""
    wps = [PROJ.reproject(60.0, 0.0), PROJ.reproject(60.0, 20.0)]
    return px4.Configuration([px4.Waypoint(lat, lon, 10.0) for lat, lon in wps], end="rtl")


def check_returned_straight_home(result: px4.MissionResult) -> None:
    """Climbed, then home on the diagonal from the last waypoint, past the box's corner."""
    assert result.completed, result.reason
    returning = [
        (n, e)
        for (n, e, _), s in zip(track(result), result.trajectory, strict=True)
        if s.mode == "AUTO.RTL"
    ]
    halfway = min(returning, key=lambda p: abs(p[0] - 30.0))
    assert 7.0 < halfway[1] < 12.0  # on the diagonal (9.7 m east there), not the first leg
    assert result.min_clearance < 2.0  # so `always (clearance >= 2)` fails, on every autopilot


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_builtin_autopilot_returns_straight_home_as_px4_does(fidelity: str) -> None:
    world = px4.WorldConfig(obstacles=(RETURN_BOX,))
    with px4.PX4(world, fidelity=fidelity).start() as sim:  # type: ignore[arg-type]
        result = sim.firmware.send(return_mission())
    check_returned_straight_home(result)


def test_real_px4_returns_straight_home(px4_sitl: RealPX4) -> None:
    world = px4.WorldConfig(obstacles=(RETURN_BOX,))
    with px4.PX4(world, fidelity="medium", firmware=px4_sitl.sitl()).start() as simulation:
        result = simulation.firmware.send(return_mission())
    check_returned_straight_home(result)
