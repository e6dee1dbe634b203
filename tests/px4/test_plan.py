"""QGroundControl plans and parameter files: read, written back, refused, flown by PX4."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import msgspec
import pytest

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.plan import Plan, read_plan
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
    # Waypoints: the relative one, the AMSL one (508 m AMSL over a 488 m home), the loiter.
    assert [round(w.alt, 6) for w in config.mission] == [15.0, 20.0, 20.0]
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
        items = doc["mission"]["items"]
        jump = {
            "autoContinue": True,
            "command": 177,
            "doJumpId": 8,
            "frame": 2,
            "params": [2, 1, 0, 0, 0, 0, 0],  # to the first waypoint (doJumpId 2), once
            "type": "SimpleItem",
        }
        items.insert(5, jump)  # after the camera item
        for i, item in enumerate(items):
            item["doJumpId"] = i + 1

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


# -- refused plans ---------------------------------------------------------------------------


def _complex(doc: Any) -> None:
    doc["mission"]["items"][3] = {"type": "ComplexItem", "complexItemType": "survey"}


def _undefined_command(doc: Any) -> None:
    doc["mission"]["items"][4]["command"] = 31999


def _terrain_frame(doc: Any) -> None:
    doc["mission"]["items"][1]["frame"] = 10


def _jump_nowhere(doc: Any) -> None:
    doc["mission"]["items"][2] = {
        "autoContinue": True,
        "command": 177,
        "doJumpId": 3,
        "frame": 2,
        "params": [42, 1, 0, 0, 0, 0, 0],
        "type": "SimpleItem",
    }


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
    assert [r.index for r in result.reached] == [0, 1, 2]
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
        items = doc["mission"]["items"]
        items.insert(
            4,
            {
                "autoContinue": True,
                "command": 177,
                "doJumpId": 0,
                "frame": 2,
                "params": [2, 1, 0, 0, 0, 0, 0],
                "type": "SimpleItem",
            },
        )
        for i, item in enumerate(items):
            item["doJumpId"] = i + 1

    config = px4.Configuration.from_plan(edited(tmp_path, add_jump))
    with px4.PX4(fidelity="low").start() as sim:
        result = sim.firmware.send(config)
    assert result.completed, result.reason
    current = [s.current for s in result.trajectory]
    # Items 1..3 twice: the jump back from item 4 to item 1, once.
    back = [i for i in range(1, len(current)) if current[i] < current[i - 1]]
    assert len(back) == 1
    assert current[back[0]] == 1
