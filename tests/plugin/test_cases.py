"""Test cases as files: a folder of ``test_*.mcs.yaml`` runs as tests, each on the PX4 fixtures."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
import yaml  # type: ignore[import-untyped]  # noqa: F401  # loaded once: in-process inner runs must not import it anew

DATA = Path(__file__).parent.parent / "data"
UAV = Path(__file__).parent.parent.parent / "scenarios" / "uav"

# The plan flies north 33 m from home, east 30 m, then south 30 m and lands.
PAST = """
description: a mast beside the first leg, a steady crosswind
plan: survey_site.plan
fidelity: [low]
obstacles:
  - {type: box, name: mast, north: 16, east: -6, length: 3, width: 3, height: 30, yaw: 10}
wind: {speed: 2, direction: 90}
requirements:
  - always (clearance >= 1.5)
"""

THROUGH = """
plan: survey_site.plan
fidelity: [low]
obstacles:
  - {type: cylinder, name: tower, north: 20, east: 0, radius: 2, height: 40}
"""


# Alpha flies north 80 m at 10 m, bravo east 80 m at 18 m across alpha's track, at about the
# time alpha passes.
CROSSING = """
vehicles:
  alpha: {plan: crossing-north.plan}
  bravo: {plan: crossing-east.plan, start: {north: 40, east: -40}}
fidelity: [low]
requirements:
  - always (separation >= 5)
"""
# Both fly to alpha's waypoint, at one height, from starts 4 m apart.
CONVERGING = """
vehicles:
  alpha: {plan: crossing-north.plan}
  bravo: {plan: crossing-north.plan, start: {east: 4}}
fidelity: [low]
"""


@pytest.fixture
def plans(pytester: pytest.Pytester) -> None:
    """The crossing's two plans beside the case files."""
    for name in ("crossing-north.plan", "crossing-east.plan"):
        shutil.copy(UAV / name, pytester.path)


@pytest.fixture
def plan(pytester: pytest.Pytester) -> Path:
    """The QGroundControl plan beside the case files."""
    return Path(shutil.copy(DATA / "survey_site.plan", pytester.path))


@pytest.mark.usefixtures("plan")
def test_folder_of_cases_runs_as_tests(pytester: pytest.Pytester) -> None:
    pytester.makefile(".mcs.yaml", test_past=PAST, test_through=THROUGH)
    result = pytester.runpytest("-p", "no:randomly", "-rA")
    result.assert_outcomes(passed=1, failed=1)
    # Named after their files, parametrized over their levels like any fidelity test.
    result.stdout.fnmatch_lines(
        [
            "PASSED test_past.mcs.yaml::test_past[[]low[]]",
            "FAILED test_through.mcs.yaml::test_through[[]low[]]*",
        ]
    )
    # A collision is the verdict, naming the obstacle the file named.
    result.stdout.fnmatch_lines(["verdict: *the vehicle hit 'tower' (cylinder) at t=*"])


@pytest.mark.usefixtures("plan")
def test_requirement_of_a_case_is_checked(pytester: pytest.Pytester) -> None:
    # The same flight, asked to keep farther from the mast than it does.
    strict = PAST.replace("clearance >= 1.5", "clearance >= 30")
    pytester.makefile(".mcs.yaml", test_strict=strict)
    result = pytester.runpytest("-p", "no:randomly")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*clearance >= 30*"])


@pytest.mark.usefixtures("plan")
def test_toml_case(pytester: pytest.Pytester) -> None:
    pytester.makefile(
        ".mcs.toml",
        test_calm="""
plan = "survey_site.plan"
fidelity = ["low"]
requirements = ["always (true_alt <= 30)"]
""",
    )
    pytester.runpytest("-p", "no:randomly").assert_outcomes(passed=1)


@pytest.mark.parametrize(
    ("text", "says"),
    [
        (PAST.replace("height: 30", "height: -1"), "*obstacles*height*-1*"),
        (PAST.replace("plan: survey_site.plan", "plan: nowhere.plan"), "*plan*nowhere.plan*file*"),
        (PAST + "speed: 3\n", "*unknown field*speed*allowed: plan, vehicles, *requirements*"),
        (PAST.replace("fidelity: [low]", "fidelity: [lowest]"), "*fidelity*lowest*low, medium*"),
        (
            PAST.replace("type: box", "type: tree"),
            "*obstacles[[]0[]].type*tree*allowed: box, cylinder*",
        ),
        (CROSSING + "plan: crossing-north.plan\n", "*plan*one vehicle's plan, or vehicles*"),
        (CROSSING + "autopilot: ardupilot\n", "*autopilot*'ardupilot'*'px4' with vehicles*"),
        (CROSSING + "well_clear: close\n", "*well_clear*'close'*NMAC*"),
        (CROSSING.replace("bravo:", "bra vo:"), "*bra vo*"),
        (CROSSING.replace("{north: 40", "{yaw: 400, north: 40"), "*yaw*400*"),
        (
            CROSSING.replace("{plan: crossing-north", "{plann: crossing-north"),
            "*plann*allowed: plan, start, params*",
        ),
        (CROSSING.replace("crossing-east.plan", "eastward.plan"), "*vehicles.bravo.plan*"),
        (PAST.replace("(clearance", "(clearence"), "*requirements[[]0[]]*'clearence'*clearance*"),
        (PAST.replace("always (", "always ((("), "*requirements[[]0[]]*"),
        (
            CROSSING.replace("separation >=", "separation_alpha_charlie >="),
            "*requirements[[]0[]]*'separation_alpha_charlie'*separation_alpha_bravo*",
        ),
    ],
    ids=[
        "negative-height",
        "missing-plan",
        "unknown-field",
        "bad-level",
        "unknown-shape",
        "fleet-plan-too",
        "fleet-ardupilot",
        "fleet-well-clear",
        "fleet-name",
        "fleet-start",
        "fleet-unknown-field",
        "fleet-no-plan",
        "misspelt-signal",
        "formula",
        "fleet-unknown-pair",
    ],
)
@pytest.mark.usefixtures("plan", "plans")
def test_malformed_case_is_a_collection_error(
    pytester: pytest.Pytester, text: str, says: str
) -> None:
    pytester.makefile(".mcs.yaml", test_bad=text)
    result = pytester.runpytest("-p", "no:randomly")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*test_bad.mcs.yaml*", says])


def test_other_yaml_files_are_left_alone(pytester: pytest.Pytester) -> None:
    pytester.makefile(".yaml", test_config="not: a case\n")
    pytester.makefile(".mcs.yaml", notes="not collected: no test_ prefix\n")
    result = pytester.runpytest("-p", "no:randomly")
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED


@pytest.mark.usefixtures("plans")
def test_a_case_of_several_vehicles_flies_them_at_once(pytester: pytest.Pytester) -> None:
    strict = CROSSING.replace("separation >= 5", "separation >= 30")
    pytester.makefile(
        ".mcs.yaml", test_crossing=CROSSING, test_strict=strict, test_converging=CONVERGING
    )
    result = pytester.runpytest("-p", "no:randomly", "-rA", "--junitxml=report.xml")
    result.assert_outcomes(passed=1, failed=2)
    result.stdout.fnmatch_lines(
        [
            # Two vehicles meeting at one waypoint collide: the pair is named, and when.
            "*alpha and bravo collided at t=* s, closing at * m/s*",
            # The requirement reads the encounter: they pass 8 m apart in height, not 30.
            "*'always (separation >= 30)' is violated*",
            "PASSED test_crossing.mcs.yaml::test_crossing[[]low[]]",
        ]
    )
    report = (pytester.path / "report.xml").read_text()
    separation = re.search(r'name="mcs_min_separation" value="([0-9.]+)"', report)
    assert separation is not None
    # Alpha at 10 m, bravo at 18 m: never closer than the 8 m between their heights less
    # their bodies, and near each other where they cross.
    assert 7.0 < float(separation[1]) < 20.0
