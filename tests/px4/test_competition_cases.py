"""The UAV test competition's case files: read in our frame, written back, scored as it scores."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import msgspec
import pytest

from multicosim import ConfigurationError
from multicosim.mavlink.mission import FlightSample
from multicosim.physics import Box, Cylinder
from multicosim.px4.competition import (
    CompetitionCase,
    Score,
    distances,
    read_case,
    score,
    write_case,
)

EXAMPLES = Path(__file__).parents[2] / "scenarios" / "uav" / "competition"


# What a still vehicle's sample holds besides its position.
_STILL = dict.fromkeys(
    ("lat", "lon", "vx", "vy", "vz", "roll", "pitch", "yaw", "true_lat", "true_lon"), 0.0
)


def _at(points: list[tuple[float, float]]) -> list[FlightSample]:
    """A flight through (north, east) points, 10 m up."""
    still = {"z": -10.0, "alt": 10.0, "true_alt": 10.0, "mode": "AUTO.MISSION", "armed": True}
    return [
        msgspec.convert({**_STILL, **still, "time": i, "x": n, "y": e, "current": 1}, FlightSample)
        for i, (n, e) in enumerate(points)
    ]


def test_case_study_reads_in_our_frame() -> None:
    case = read_case(EXAMPLES / "two-blocks.yaml")
    assert case.mission_file == EXAMPLES / "out-and-back.plan"
    assert case.params_file == EXAMPLES / "flight-params.csv"
    assert case.params["MPC_XY_CRUISE"] == 5.0
    # x is north, y east, the position the box's centre, r degrees clockwise from north.
    assert case.obstacles == (
        Box(north=3, east=25, length=4, width=4, height=15, yaw=0),
        Box(north=-20, east=30, length=6, width=4, height=20, yaw=30),
    )


def test_generator_output_names_files_from_where_it_ran(tmp_path: Path) -> None:
    # A generator ran in tmp_path and wrote its cases two folders down, naming the case
    # study's files from where it ran; parameters and commands inline, as it saves them.
    shutil.copy(EXAMPLES / "out-and-back.plan", tmp_path / "mission.plan")
    out = tmp_path / "generated_tests" / "29-11-10-00-00"
    out.mkdir(parents=True)
    (out / "test_0.yaml").write_text(
        "drone: {mission_file: mission.plan, params: {NAV_ACC_RAD: 0.5}, port: 14541}\n"
        "simulation:\n  obstacles:\n"
        "  - {position: {r: 90, x: 10, y: 20, z: 0}, size: {h: 12, l: 10, w: 5}}\n"
        "  timeout: 300\n"
        "test: {commands: [{mode: 3, r: 0, timestamp: 1, x: 0, y: 0, z: 0.5}]}\n"
    )
    case = read_case(out / "test_0.yaml")
    assert case.mission_file == tmp_path / "mission.plan"
    assert case.params == {"NAV_ACC_RAD": 0.5}
    assert case.params_file is None
    assert case.timeout == 300
    # Turned 90 degrees, its 10 m length lies east-west: 6 m east of the centre is 1 m out.
    (box,) = case.obstacles
    assert distances(_at([(10, 26)]), case.obstacles) == [pytest.approx(1 - 0.125)]
    assert box == Box(north=10, east=20, length=10, width=5, height=12, yaw=90)


def test_flat_obstacles_and_cylinders(tmp_path: Path) -> None:
    shutil.copy(EXAMPLES / "dogleg.plan", tmp_path)
    body = "drone: {mission_file: dogleg.plan}\ntest: {commands: [{mode: 3, timestamp: 0}]}\n"
    (tmp_path / "flat.yaml").write_text(body + "simulation: {obstacles: [5,5,5, 10,5,0, 0]}\n")
    (tmp_path / "round.yaml").write_text(
        body + "simulation:\n  obstacles:\n  - shape: cylinder\n"
        "    size: {l: 4, w: 4, h: 20, r: 2}\n    position: {x: 20, y: 5, z: 0, r: 0}\n"
    )
    assert read_case(tmp_path / "flat.yaml").obstacles == (
        Box(north=10, east=5, length=5, width=5, height=5),
    )
    assert read_case(tmp_path / "round.yaml").obstacles == (
        Cylinder(north=20, east=5, radius=2, height=20),
    )


@pytest.mark.parametrize(
    ("change", "field", "says"),
    [
        (("z: 0}", "z: 2}"), "simulation.obstacles[0].position.z", "stands on the ground"),
        (("l: 5,", "l: -5,"), "simulation.obstacles[0].size.l", "at least 0"),
        (("mode: 3", "mode: 4"), "test.commands[0].mode", "'4 (Hold)'"),
        (("timeout: 300", "wind: {velocity_mean: 3}"), "simulation.wind", "a field of"),
        (("mission_file: dogleg.plan", "mission_file: gone.plan"), "drone.mission_file", "file"),
        (("x: -7.5, y: 30", "x: 1, y: 1"), "simulation.obstacles[0]", "from home"),
    ],
    ids=["off-the-ground", "negative-length", "hold-command", "wind", "no-plan", "over-home"],
)
def test_bad_case_names_file_field_and_value(
    tmp_path: Path, change: tuple[str, str], field: str, says: str
) -> None:
    shutil.copy(EXAMPLES / "dogleg.plan", tmp_path)
    text = (EXAMPLES / "dogleg.yaml").read_text()
    assert change[0] in text
    (tmp_path / "case.yaml").write_text(text.replace(*change))
    with pytest.raises(ConfigurationError) as caught:
        read_case(tmp_path / "case.yaml")
    assert caught.value.field == f"{tmp_path / 'case.yaml'}: {field}"
    assert says in str(caught.value)


def test_commands_other_than_the_mission_start_are_refused(tmp_path: Path) -> None:
    shutil.copy(EXAMPLES / "dogleg.plan", tmp_path)
    (tmp_path / "manual.csv").write_text("timestamp,mode,x,y,z,r\n1,3,0,0,0.5,0\n9,5,0,0,0.5,0\n")
    (tmp_path / "case.yaml").write_text(
        "drone: {mission_file: dogleg.plan}\nsimulation: {}\ntest: {commands_file: manual.csv}\n"
    )
    with pytest.raises(ConfigurationError, match=r"2 commands.*mode 3 \(Mission\)"):
        read_case(tmp_path / "case.yaml")


def test_write_and_read_back_keeps_the_case(tmp_path: Path) -> None:
    for name in ("two-blocks.yaml", "dogleg.yaml"):
        case = read_case(EXAMPLES / name)
        write_case(case, tmp_path / name)
        assert read_case(tmp_path / name) == case
    cylinder = CompetitionCase(
        EXAMPLES / "dogleg.plan", obstacles=(Cylinder(north=9, east=9, radius=2, height=30),)
    )
    write_case(cylinder, tmp_path / "cylinder.yaml")
    assert read_case(tmp_path / "cylinder.yaml") == cylinder


def test_distance_is_to_the_track_between_samples() -> None:
    box = Box(north=0, east=25, length=4, width=4, height=15)
    # Two samples far from the box on either side: the line between them crosses it.
    assert distances(_at([(-10, 20), (10, 30)]), [box]) == [0.0]
    # A leg 5 m south of the box's centre: 3 m from its edge, less half the track's width.
    assert distances(_at([(-5, 0), (-5, 50)]), [box]) == [pytest.approx(2.875)]
    assert distances(_at([(-5, 0), (-5, 50)]), []) == []


@pytest.mark.parametrize(
    ("nearest", "collided", "point", "verdict"),
    [
        (0.1, True, 5, "hard fail"),
        (0.1, False, 5, "soft fail"),
        (0.25, False, 2, "soft fail"),
        (1.0, False, 1, "soft fail"),
        (1.5, False, 0, "pass"),
        (math.inf, False, 0, "pass"),
    ],
)
def test_points_and_verdict_follow_the_thresholds(
    nearest: float, collided: bool, point: int, verdict: str
) -> None:
    judged = Score((nearest, 30.0) if math.isfinite(nearest) else (), collided)
    assert (judged.min_distance, judged.point, judged.verdict) == (nearest, point, verdict)


def test_score_of_a_flight() -> None:
    box = Box(north=0, east=25, length=4, width=4, height=15)
    far = Cylinder(north=40, east=0, radius=1, height=20)
    judged = score(_at([(-3, 0), (-3, 50)]), [box, far], collided=False)
    assert judged.distances == pytest.approx((0.875, 43 - 1.125))
    assert (judged.point, judged.verdict) == (2, "soft fail")
