"""QGroundControl plans and parameter files: read, written back, refused, flown by PX4."""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.plan import (
    FenceCircle,
    FencePolygon,
    Plan,
    PlanItem,
    RallyPoint,
    read_plan,
    write_plan,
)
from pytest_multicosim.px4 import RealPX4

DATA = Path(__file__).parent.parent / "data"
PLAN = DATA / "survey_site.plan"
HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
LAND_AT = PROJ.project(47.397742, 8.545994)  # the plan's land item


def meaning(plan: Plan) -> Any:
    """What a plan says, NaN (unset) as None so that equal plans compare equal."""

    def clean(value: Any) -> Any:
        if isinstance(value, float) and math.isnan(value):
            return None
        if isinstance(value, list | tuple):
            return [clean(v) for v in value]
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        return value

    return clean(msgspec.to_builtins(plan))


def unplaced(command: int, *params: float) -> dict[str, Any]:
    """A simple item without a position (frame 2), as QGroundControl saves it."""
    return {
        "autoContinue": True,
        "command": command,
        "doJumpId": 0,  # numbered by insert_item or the caller
        "frame": 2,
        "params": [*params, *[0] * (7 - len(params))],
        "type": "SimpleItem",
    }


def insert_item(doc: Any, index: int, item: dict[str, Any]) -> None:
    """Insert ``item`` into the mission at ``index``, renumbering doJumpIds as QGC does."""
    items = doc["mission"]["items"]
    items.insert(index, item)
    for i, it in enumerate(items):
        it["doJumpId"] = i + 1


def edited(tmp_path: Path, change: Any) -> Path:
    """The test plan with ``change(doc)`` applied, written to a new file."""
    doc = json.loads(PLAN.read_text())
    change(doc)
    path = tmp_path / "edited.plan"
    path.write_text(json.dumps(doc))
    return path


# -- reading and writing -----------------------------------------------------------------------


def test_a_qgc_plan_reads_as_its_mission_fence_and_rally_points() -> None:
    config = px4.Configuration.from_plan(PLAN)
    plan = config.plan
    assert plan is not None
    # Waypoints: the relative one, the AMSL one (508 m AMSL over a 488 m home), the loiter,
    # the landing's own position.
    assert [round(w.alt, 6) for w in config.mission] == [15.0, 20.0, 20.0, 0.0]
    assert [it.command for it in plan.items] == [22, 16, 178, 16, 2000, 19, 21]
    assert [it.frame for it in plan.items] == [3, 3, 2, 0, 2, 3, 3]
    assert plan.items[5].params[0] == 5.0  # loiter for 5 s
    assert plan.items[2].params[1] == 3.0  # then 3 m/s
    assert config.end == "land"
    assert config.cruise_speed == 5.0  # the plan's hoverSpeed
    assert plan.home == (HOME.lat, HOME.lon, HOME.alt)
    assert [p.inclusion for p in plan.polygons] == [True]
    assert len(plan.polygons[0].vertices) == 4
    assert [(c.radius, c.inclusion) for c in plan.circles] == [(15.0, False)]
    assert [r.alt for r in plan.rally] == [20.0, 25.0]
    fence = plan.fence_items()
    assert [it.command for it in fence] == [5001] * 4 + [5004]
    assert all(it.params[0] == 4.0 for it in fence[:4])  # vertex count


def test_a_plan_round_trips_through_to_plan(tmp_path: Path) -> None:
    config = px4.Configuration.from_plan(PLAN)
    out = tmp_path / "out.plan"
    config.to_plan(out)
    again = px4.Configuration.from_plan(out)
    assert again.plan is not None
    assert config.plan is not None
    assert meaning(again.plan) == meaning(config.plan)
    assert again.mission == config.mission
    assert again.end == config.end
    # What QGroundControl needs to open it, as it writes it itself.
    doc = json.loads(out.read_text())
    original = json.loads(PLAN.read_text())
    assert (doc["fileType"], doc["version"], doc["mission"]["version"]) == ("Plan", 1, 2)
    assert doc["geoFence"] == original["geoFence"]
    assert doc["rallyPoints"] == original["rallyPoints"]
    assert doc["mission"]["items"] == original["mission"]["items"]


def test_do_jump_targets_survive_the_round_trip(tmp_path: Path) -> None:
    def add_jump(doc: Any) -> None:
        # After the camera item: to the first waypoint (doJumpId 2), once.
        insert_item(doc, 5, unplaced(177, 2, 1))

    config = px4.Configuration.from_plan(edited(tmp_path, add_jump))
    assert config.plan is not None
    assert config.plan.items[5].params[:2] == (1.0, 1.0)  # the index of the first waypoint
    out = tmp_path / "jump.plan"
    config.to_plan(out)
    assert json.loads(out.read_text())["mission"]["items"][5]["params"][0] == 2
    assert meaning(read_plan(out)) == meaning(config.plan)


def test_a_plain_configuration_writes_a_plan_that_reads_back(tmp_path: Path) -> None:
    lat, lon = PROJ.reproject(40.0, 10.0)
    config = px4.Configuration([px4.Waypoint(lat, lon, 12.0)], end="rtl", cruise_speed=4.0)
    out = tmp_path / "plain.plan"
    with pytest.raises(mcs.ConfigurationError, match="home"):
        config.to_plan(out)
    config.to_plan(out, home=HOME)
    again = px4.Configuration.from_plan(out)
    assert again.mission == config.mission
    assert (again.end, again.cruise_speed) == ("rtl", 4.0)


def test_whole_numbers_written_as_python_ints_read_back(tmp_path: Path) -> None:
    lat, lon = PROJ.reproject(40.0, 10.0)
    # ints where floats are declared, as a user's literal writes them
    config = px4.Configuration([px4.Waypoint(lat, lon, 12)], cruise_speed=4)
    out = tmp_path / "ints.plan"
    config.to_plan(out, home=HOME)
    again = px4.Configuration.from_plan(out)
    assert again.mission[0].alt == 12.0
    assert again.cruise_speed == 4.0


# -- refused plans ---------------------------------------------------------------------------


def _complex(doc: Any) -> None:
    doc["mission"]["items"][3] = {"type": "ComplexItem", "complexItemType": "survey"}


def _undefined_command(doc: Any) -> None:
    doc["mission"]["items"][4]["command"] = 31999


def _terrain_frame(doc: Any) -> None:
    doc["mission"]["items"][1]["frame"] = 10


def _jump_nowhere(doc: Any) -> None:
    doc["mission"]["items"][2] = {**unplaced(177, 42, 1), "doJumpId": 3}


def _not_a_plan(doc: Any) -> None:
    doc["fileType"] = "GeoFence"


def _tiny_polygon(doc: Any) -> None:
    doc["geoFence"]["polygons"][0]["polygon"] = doc["geoFence"]["polygons"][0]["polygon"][:2]


def _short_params(doc: Any) -> None:
    doc["mission"]["items"][1]["params"] = [0, 0, 0]


@pytest.mark.parametrize(
    ("change", "field", "says"),
    [
        (_complex, "mission.items[3].complexItemType", "unexpanded"),
        (_undefined_command, "mission.items[4].command", "MAVLink defines"),
        (_terrain_frame, "mission.items[1].frame", "relative to home"),
        (_jump_nowhere, "mission.items[2].params[0]", "doJumpId"),
        (_not_a_plan, "fileType", "QGroundControl plan"),
        (_tiny_polygon, "geoFence.polygons[0].polygon", "three vertices"),
        (_short_params, "mission.items[1].params", "seven"),
    ],
)
def test_a_bad_plan_is_refused_naming_file_and_field(
    tmp_path: Path, change: Any, field: str, says: str
) -> None:
    path = edited(tmp_path, change)
    with pytest.raises(mcs.ConfigurationError, match=says) as info:
        px4.Configuration.from_plan(path)
    assert info.value.field == f"{path}: {field}"


def test_malformed_json_is_refused_with_its_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.plan"
    path.write_text(PLAN.read_text().replace('"groundStation"', "groundStation", 1))
    with pytest.raises(mcs.ConfigurationError, match="JSON") as info:
        px4.Configuration.from_plan(path)
    assert info.value.field.startswith(f"{path}: line ")


def test_a_missing_plan_file_is_refused() -> None:
    with pytest.raises(mcs.ConfigurationError, match="readable"):
        px4.Configuration.from_plan(DATA / "no_such.plan")


# -- parameter files ---------------------------------------------------------------------------


def test_parameter_files_in_three_formats() -> None:
    assert px4.read_params(DATA / "slow_climb.params") == {
        "MPC_TKO_SPEED": 1.0,
        "MPC_Z_V_AUTO_UP": 1.0,
        "NAV_RCL_ACT": 2.0,
    }
    assert px4.read_params(DATA / "slow_climb_px4.txt") == {
        "MPC_TKO_SPEED": 1.0,
        "MPC_Z_V_AUTO_UP": 1.0,
    }
    assert px4.read_params(DATA / "slow_climb_copter.csv") == {
        "WPNAV_SPEED_UP": 100.0,
        "PILOT_SPEED_UP": 100.0,
    }


@pytest.mark.parametrize(
    ("text", "line", "value", "says"),
    [
        ("MPC_TKO_SPEED=1\n", 1, "MPC_TKO_SPEED=1", "parameter file"),
        ("# speeds\nparam set MPC_TKO_SPEED fast\n", 2, "fast", "finite number"),
        ("param set MPC_TKO_SPEED 1\nMPC_Z_V_AUTO_UP,1\n", 2, "MPC_Z_V_AUTO_UP,1", "format"),
        ("name,value\nmpc_tko_speed,1\n", 2, "mpc_tko_speed", "parameter name"),
        ("1\t1\tNAV_RCL_ACT\t2.5\t6\n", 1, "2.5", "integer"),
        ("1\t1\tNAV_RCL_ACT\t2\t42\n", 1, "42", "MAV_PARAM_TYPE"),
        ("A,nan\n", 1, "nan", "finite number"),
    ],
)
def test_a_bad_parameter_file_is_refused_naming_line_and_value(
    tmp_path: Path, text: str, line: int, value: str, says: str
) -> None:
    path = tmp_path / "bad.params"
    path.write_text(text)
    with pytest.raises(mcs.ConfigurationError, match=says) as info:
        px4.read_params(path)
    assert info.value.field.startswith(f"{path}: line {line}")
    assert info.value.value == value


# -- flown -------------------------------------------------------------------------------------


def climb_rate(result: px4.MissionResult) -> float:
    """The fastest climb (m/s) while taking off to the plan's first altitude."""
    return max(-s.vz for s in result.trajectory if s.alt < 13.0)


def check_flown(result: px4.MissionResult) -> None:
    """The test plan flown: every waypoint reached in order, landed where it says."""
    assert result.completed, result.reason
    # Three waypoints, then the landing at its own position.
    assert [r.index for r in result.reached] == [0, 1, 2, 3]
    times = [r.time for r in result.reached]
    # 30 m east at the plan's 3 m/s, then 33 m south and the 5 s loiter.
    assert times[1] - times[0] >= 30.0 / 3.3
    assert times[2] - times[1] >= 33.0 / 3.3 + 5.0
    assert result.landed
    assert not result.armed
    last = result.trajectory[-1]
    n, e = PROJ.project(last.true_lat, last.true_lon)
    assert math.hypot(n - LAND_AT[0], e - LAND_AT[1]) < 3.0


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_builtin_autopilot_flies_a_qgc_plan(fidelity: str) -> None:
    config = px4.Configuration.from_plan(PLAN)
    params = px4.read_params(DATA / "slow_climb_px4.txt")
    with px4.PX4(fidelity=fidelity, params=params).start() as sim:  # type: ignore[arg-type]
        result = sim.firmware.send(config)
        autopilot = sim.firmware.autopilot
        fence = [(it.command, it.param1) for it in autopilot.fence] if autopilot else []
        rally = len(autopilot.rally) if autopilot else 0
    check_flown(result)
    # The camera command is noted, not refused.
    assert "Item 4: IMAGE_START_CAPTURE has no effect" in result.messages
    if fidelity == "low":  # in this process: the autopilot's stores can be looked at
        assert fence == [(5001, 4.0)] * 4 + [(5004, 15.0)]
        assert rally == 2
    assert climb_rate(result) < 1.3  # the parameter file's 1 m/s, not PX4's 3


def test_real_px4_flies_a_qgc_plan_with_its_fence_and_rally_points(px4_sitl: RealPX4) -> None:
    config = px4.Configuration.from_plan(PLAN)
    params = px4.read_params(DATA / "slow_climb.params")
    simulator = px4.PX4(fidelity="medium", firmware=px4_sitl.sitl(), params=params)
    with simulator.start() as simulation:
        result = simulation.firmware.send(config)
    check_flown(result)
    assert not [m for m in result.messages if "unsupported" in m.lower()]
    assert climb_rate(result) < 1.3


def test_the_builtin_autopilot_flies_a_do_jump_again(tmp_path: Path) -> None:
    def add_jump(doc: Any) -> None:
        insert_item(doc, 4, unplaced(177, 2, 1))  # after item 3, back to item 1, once

    config = px4.Configuration.from_plan(edited(tmp_path, add_jump))
    with px4.PX4(fidelity="low").start() as sim:
        result = sim.firmware.send(config)
    assert result.completed, result.reason
    current = [s.current for s in result.trajectory]
    # Items 1..3 twice: the jump back from item 4 to item 1, once.
    back = [i for i in range(1, len(current)) if current[i] < current[i - 1]]
    assert len(back) == 1
    assert current[back[0]] == 1


def _into_exclusion(doc: Any) -> None:
    doc["mission"]["items"][3]["params"][4:6] = [47.397342, 8.545294]  # 7.5 m from its centre


def _out_of_inclusion(doc: Any) -> None:
    doc["mission"]["items"][3]["params"][4:6] = [47.399742, 8.545994]  # 200 m north


@pytest.mark.parametrize("change", [_into_exclusion, _out_of_inclusion])
def test_the_builtin_autopilot_refuses_a_mission_its_plans_fence_forbids(
    tmp_path: Path, change: Any
) -> None:
    config = px4.Configuration.from_plan(edited(tmp_path, change))
    with px4.PX4(fidelity="low").start() as sim:
        result = sim.firmware.send(config)
    assert not result.completed
    assert result.reason == "Mission rejected: geofence violation, item 3"
    assert not result.armed


def test_real_px4_refuses_a_mission_its_plans_fence_forbids(
    px4_sitl: RealPX4, tmp_path: Path
) -> None:
    config = px4.Configuration.from_plan(edited(tmp_path, _into_exclusion))
    with px4.PX4(fidelity="medium", firmware=px4_sitl.sitl()).start() as simulation:
        result = simulation.firmware.send(config)
    assert not result.completed
    assert "Geofence violation for waypoint 4" in result.messages  # PX4 counts from 1
    assert not result.reached


@st.composite
def plans(draw: st.DrawFn) -> Plan:
    """Plans of any simple items, fences and rally points QGroundControl could save."""
    lat = st.floats(-89.0, 89.0)
    lon = st.floats(-179.0, 179.0)
    param = st.floats(-1e6, 1e6) | st.just(math.nan)
    n = draw(st.integers(1, 8))
    items = []
    for _ in range(n):
        command = draw(st.sampled_from([16, 17, 19, 20, 21, 22, 178, 177, 2000, 203, 201]))
        if command == 177:
            target = draw(st.integers(0, n - 1))
            params = (float(target), draw(st.floats(-1, 10)), 0.0, 0.0, 0.0, 0.0, 0.0)
            items.append(PlanItem(command, 2, params))
            continue
        frame = draw(st.sampled_from([0, 3, 5, 6])) if command < 100 else 2
        position = (draw(lat), draw(lon), draw(st.floats(0, 500))) if frame != 2 else (0.0,) * 3
        p1, p2, p3, p4 = (draw(param) for _ in range(4))
        params = (p1, p2, p3, p4, *position)
        items.append(PlanItem(command, frame, params, draw(st.booleans())))
    vertices = st.lists(st.tuples(lat, lon), min_size=3, max_size=6)
    radius = st.floats(0.5, 1e4)
    return Plan(
        items=items,
        home=(draw(lat), draw(lon), draw(st.floats(-100, 4000))),
        cruise_speed=draw(st.floats(0.1, 50)),
        hover_speed=draw(st.floats(0.1, 20)),
        polygons=draw(st.lists(st.builds(FencePolygon, vertices, st.booleans()), max_size=2)),
        circles=draw(st.lists(st.builds(FenceCircle, lat, lon, radius, st.booleans()), max_size=2)),
        rally=draw(st.lists(st.builds(RallyPoint, lat, lon, st.floats(0, 500)), max_size=3)),
    )


@given(plan=plans())
@settings(max_examples=60, deadline=None)
def test_any_plan_round_trips_unchanged_in_meaning(plan: Plan) -> None:
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "any.plan"
        write_plan(plan, path)
        assert meaning(read_plan(path)) == meaning(plan)


def _return_instead_of_landing(doc: Any) -> None:
    doc["mission"]["items"][6] = {**unplaced(20), "doJumpId": 7}


RALLY_2 = PROJ.project(47.397542, 8.546194)  # 26.6 m from the loiter point, home 30 m


@pytest.mark.parametrize("real", [False, True], ids=["builtin", "real"])
def test_a_plans_return_lands_at_its_closest_rally_point(
    tmp_path: Path, real: bool, request: pytest.FixtureRequest
) -> None:
    firmware = request.getfixturevalue("px4_sitl").sitl() if real else None
    config = px4.Configuration.from_plan(edited(tmp_path, _return_instead_of_landing))
    assert config.end == "rtl"
    simulator = px4.PX4(fidelity="medium" if real else "low", firmware=firmware)
    with simulator.start() as simulation:
        result = simulation.firmware.send(config)
    assert result.completed, result.reason
    last = result.trajectory[-1]
    n, e = PROJ.project(last.true_lat, last.true_lon)
    assert math.hypot(n - RALLY_2[0], e - RALLY_2[1]) < 3.0
