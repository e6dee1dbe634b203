"""Failing fixture-based runs explain themselves: traces read by an independent reader.

A suite of failing PX4 and rover tests (low and medium fidelity, through the scenario
fixtures) runs in pytester. Their traces are opened with the mcap library's own reader, every
``foxglove.*`` message is validated against Foxglove's published schemas, the plot's axes are
checked against the world's truth, the ``.tlog`` is read back by pymavlink, the layout names
channels the trace has, and the JUnit XML names each failure's trace and replay command.
"""

from __future__ import annotations

import json
import math
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from independent import read_independently, validate_foxglove
from pymavlink import mavutil

from multicosim.core.geo import EARTH_RADIUS
from multicosim.placement import default_placement
from multicosim.trace import read_trace
from multicosim.trace._plot import figure

HOME = (47.397742, 8.545594)  # px4.Home() defaults: PX4 SITL's home
WAYPOINT = (47.3980, 8.5460)

SUITE = f"""
import pytest

import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim.search.requirements import Requirement


@pytest.mark.fidelity("low", "medium")
def test_px4_stays_below_10_m(px4_simulation):
    mission = px4.Configuration(
        [px4.Waypoint(lat={WAYPOINT[0]}, lon={WAYPOINT[1]}, alt=15.0)], time_limit=120.0
    )
    result = px4_simulation.firmware.send(mission)
    assert result.completed, result.reason
    Requirement("always (true_alt <= 10)").check(result.trajectory)


@pytest.mark.fidelity("low", "medium")
def test_rover_drives_backwards(rover_simulation):
    trajectory = rover_simulation.controller.send(
        rover.Mission(speed=3.0, wait=0.0, distance=3.0, final_distance=2.0)
    )
    assert trajectory.final.x < 0, "the rover drove forwards"
"""

INI = """\
[pytest]
addopts = --strict-markers -p no:cacheprovider
filterwarnings = error
"""


@pytest.fixture(scope="module")
def failing_run(
    tmp_path_factory: pytest.TempPathFactory, inner_env: dict[str, str]
) -> tuple[Path, str]:
    """Run the failing suite once (four failures); yield its directory and its output."""
    path = tmp_path_factory.mktemp("failing_run")
    (path / "pytest.ini").write_text(INI)
    (path / "test_failing.py").write_text(SUITE)
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "--mcs-fidelity=low,medium",
            "--mcs-artifacts=arts",
            "--junitxml=junit.xml",
            "-p",
            "no:xdist",
        ],
        cwd=path,
        env=inner_env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert "4 failed" in result.stdout, result.stdout[-4000:] + result.stderr[-2000:]
    return path, result.stdout


def artifacts(path: Path, test: str) -> Path:
    # Each fidelity's default placement: in-process at low, local processes above.
    placement = default_placement("low" if test.endswith("_low") else "medium")
    return path / "arts" / f"test_failing.py_{test}" / f"seed-0-{placement}"


CASES = [
    ("test_px4_stays_below_10_m_low", "px4"),
    ("test_px4_stays_below_10_m_medium", "px4"),
    ("test_rover_drives_backwards_low", "rover"),
    ("test_rover_drives_backwards_medium", "rover"),
]


@pytest.mark.parametrize(("test", "scenario"), CASES)
def test_the_trace_of_a_failing_fixture_test_is_valid_foxglove_data(
    failing_run: tuple[Path, str], test: str, scenario: str
) -> None:
    path, _ = failing_run
    trace = artifacts(path, test) / "trace.mcap"
    schemas, messages = read_independently(trace)

    foxglove, validated = validate_foxglove(schemas, messages)
    # Every other channel declares its dialect and its first messages match its schema.
    for topic, (_, schema) in schemas.items():
        assert schema.get("$schema") == "https://json-schema.org/draft/2020-12/schema", topic
        for _, data in messages[topic][:20]:
            jsonschema.Draft202012Validator(schema).validate(data)
    assert validated > 100

    if scenario == "px4":
        assert {
            "px4/location/estimate": "foxglove.LocationFix",
            "px4/location/truth": "foxglove.LocationFix",
            "px4/pose": "foxglove.PoseInFrame",
            "px4/log": "foxglove.Log",
            "px4/mission": "foxglove.GeoJSON",
        }.items() <= foxglove.items()
        # MAVLink decoded into typed channels, one per message type, both directions.
        for kind in ("HEARTBEAT", "STATUSTEXT", "POSITION_TARGET_LOCAL_NED", "ATTITUDE"):
            assert schemas[f"px4/mavlink/down/{kind}"][0] == f"mavlink.common.{kind}"
        assert schemas["px4/mavlink/up/MISSION_ITEM_INT"][0] == "mavlink.common.MISSION_ITEM_INT"
        assert "px4/mavlink/down" not in schemas  # no channel of raw frames
        # A world without obstacles: no obstacles, for the plot or the 3D panel.
        assert not {"mcs/obstacles", "mcs/scene"} & set(schemas)
        assert "foxglove.SceneUpdate" not in foxglove.values()
        heartbeat = messages["px4/mavlink/down/HEARTBEAT"][-1][1]
        assert heartbeat["autopilot"] == 12  # MAV_AUTOPILOT_PX4
        # The mission on the map: home and the waypoint, in GeoJSON's lon/lat order.
        shapes = json.loads(messages["px4/mission"][-1][1]["geojson"])
        line = shapes["features"][0]["geometry"]
        assert line["type"] == "LineString"
        assert line["coordinates"][0] == pytest.approx([HOME[1], HOME[0]])
        assert [WAYPOINT[1], WAYPOINT[0]] in [pytest.approx(c) for c in line["coordinates"]]
        # STATUSTEXT became log lines; the attitude is not the identity once flying.
        assert any("mission" in m["message"].lower() for _, m in messages["px4/log"])
        tilted = [
            m["pose"]["orientation"]
            for _, m in messages["px4/pose"]
            if abs(m["pose"]["orientation"]["w"]) < 0.99
        ]
        assert tilted, "the pose never left the identity: the attitude is not recorded"
    else:
        assert {
            "mcs/location": "foxglove.LocationFix",
            "mcs/pose": "foxglove.PoseInFrame",
        }.items() <= (foxglove.items())


def equirectangular(lat: float, lon: float) -> tuple[float, float]:
    """East and north (m) of a point from HOME: a projection of our own, good to a few cm here."""
    north = math.radians(lat - HOME[0]) * EARTH_RADIUS
    east = math.radians(lon - HOME[1]) * EARTH_RADIUS * math.cos(math.radians(HOME[0]))
    return east, north


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_px4_plot_draws_east_right_north_up_with_the_plan_and_the_violation(
    failing_run: tuple[Path, str], fidelity: str
) -> None:
    path, _ = failing_run
    directory = artifacts(path, f"test_px4_stays_below_10_m_{fidelity}")
    assert (directory / "trace.png").read_bytes().startswith(b"\x89PNG")
    trace = read_trace(directory / "trace.mcap")
    fig = figure(trace)
    ax_path, _, ax_rob = fig.axes
    assert (ax_path.get_xlabel(), ax_path.get_ylabel()) == ("east (m)", "north (m)")
    lines: dict[object, Any] = {line.get_gid(): line for ax in fig.axes for line in ax.get_lines()}

    # The truth path is the world's truth: east on x, north on y.
    truth = [m.data for m in trace.topic("px4/truth")]
    assert list(lines["path/truth"].get_xdata()) == pytest.approx([t["east"] for t in truth])
    assert list(lines["path/truth"].get_ydata()) == pytest.approx([t["north"] for t in truth])
    assert lines["path/truth"].get_label().startswith("truth")
    assert lines["path/estimate"].get_label().startswith("estimate")
    # The vehicle flew to the waypoint, north-east of home: that is where the line goes.
    east, north = equirectangular(*WAYPOINT)
    far = max(range(len(truth)), key=lambda i: truth[i]["east"] ** 2 + truth[i]["north"] ** 2)
    assert lines["path/truth"].get_xdata()[far] == pytest.approx(east, abs=3.0)
    assert lines["path/truth"].get_ydata()[far] == pytest.approx(north, abs=3.0)
    # The plan is drawn, ending at the waypoint.
    plan = lines["plan"]
    assert plan.get_xdata()[-1] == pytest.approx(east, abs=0.5)
    assert plan.get_ydata()[-1] == pytest.approx(north, abs=0.5)

    # The requirement's own signal is plotted, and its first violation marked.
    samples = [m.data for m in trace.topic("mcs/trajectory")]
    signal = lines["signal/true_alt"]
    assert list(signal.get_ydata()) == pytest.approx([s["true_alt"] for s in samples])
    first = next(s["time"] for s in samples if s["true_alt"] > 10.0)
    rob_lines: list[Any] = ax_rob.get_lines()
    marks = {line.get_label(): line.get_xdata()[0] for line in rob_lines}
    first_mark = next(x for label, x in marks.items() if label.startswith("first violation"))
    assert first_mark == pytest.approx(first)
    assert any(label.startswith("worst time") for label in marks)


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_rover_plot_draws_the_worlds_position(
    failing_run: tuple[Path, str], fidelity: str
) -> None:
    path, _ = failing_run
    trace = read_trace(artifacts(path, f"test_rover_drives_backwards_{fidelity}") / "trace.mcap")
    lines: dict[object, Any] = {
        line.get_gid(): line for ax in figure(trace).axes for line in ax.get_lines()
    }
    positions = [m.data for m in trace.topic("rover/position")]
    # What the world's position sensor published (noisy at medium): not called the truth.
    measured = lines["path/measured"]
    assert measured.get_label().startswith("measured")
    assert list(measured.get_xdata()) == pytest.approx([p["x"] for p in positions])
    assert list(measured.get_ydata()) == pytest.approx([p["y"] for p in positions])


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_the_mavlink_traffic_is_a_tlog_that_pymavlink_reads(
    failing_run: tuple[Path, str], fidelity: str
) -> None:
    path, _ = failing_run
    tlog = artifacts(path, f"test_px4_stays_below_10_m_{fidelity}") / "trace.tlog"
    log = mavutil.mavlink_connection(str(tlog), dialect="common")
    kinds: dict[str, int] = {}
    times: list[float] = []
    while (message := log.recv_match()) is not None:
        kinds[message.get_type()] = kinds.get(message.get_type(), 0) + 1
        times.append(message._timestamp)
    log.close()
    assert "BAD_DATA" not in kinds
    assert {"HEARTBEAT", "MISSION_ITEM_INT", "COMMAND_LONG", "GLOBAL_POSITION_INT"} <= set(kinds)
    assert times == sorted(times)
    assert times[-1] > 10.0  # simulated seconds


@pytest.mark.parametrize(("test", "scenario"), CASES)
def test_the_layout_shows_channels_the_trace_has(
    failing_run: tuple[Path, str], test: str, scenario: str
) -> None:
    path, _ = failing_run
    directory = artifacts(path, test)
    layout = json.loads((directory / "trace.layout.json").read_text())
    topics = set(read_trace(directory / "trace.mcap").channels)
    configs = layout["configById"]
    kinds = {panel.split("!")[0] for panel in configs}
    assert {"map", "3D", "Plot"} <= kinds
    plotted = [p["value"] for c in configs.values() for p in c.get("paths", ())]
    assert plotted
    assert all(value.split(".")[0] in topics for value in plotted)
    if scenario == "px4":
        assert "mcs/trajectory.true_alt" in plotted  # the requirement's signal
        assert "mcs/robustness.margin" in plotted
        assert "px4/mavlink/down/POSITION_TARGET_LOCAL_NED.z" in plotted  # setpoint...
        assert "px4/mavlink/down/LOCAL_POSITION_NED.z" in plotted  # ... beside the value
        assert configs["RosOut!mcs"]["topicToRender"] == "px4/log"
        assert configs["map!mcs"]["followTopic"] == "px4/location/estimate"

    def panels(node: Any) -> Iterator[str]:
        if isinstance(node, str):
            yield node
        else:
            yield from panels(node["first"])
            yield from panels(node["second"])

    assert sorted(panels(layout["layout"])) == sorted(configs)


def test_the_report_and_the_junit_xml_name_trace_and_replay(failing_run: tuple[Path, str]) -> None:
    path, stdout = failing_run
    # Our frames are hidden: the traceback ends in the test, the verdict comes first.
    assert "multicosim/requirements.py" not in stdout
    assert stdout.count("verdict: ") == 4
    assert "verdict: multicosim.RequirementViolation: requirement " in stdout
    assert "first violated at t=" in stdout
    assert "open: Foxglove" in stdout

    tree = ET.parse(path / "junit.xml")
    cases = tree.getroot().findall(".//testcase")
    assert len(cases) == 4
    for case in cases:
        assert case.find("failure") is not None
        properties = {p.get("name"): p.get("value") for p in case.iter("property")}
        assert properties["mcs_seed"] == "0"
        replay = shlex.split(str(properties["mcs_replay"]))
        assert replay[:3] == [sys.executable, "-m", "pytest"]
        assert replay[3].startswith(f"{path}/test_failing.py::")
        assert "--mcs-seed=0" in replay
        for kind, suffix in (("trace", ".mcap"), ("plot", ".png"), ("layout", ".json")):
            value = Path(str(properties[f"mcs_{kind}"]))
            assert value.suffix == suffix
            assert value.is_file()
