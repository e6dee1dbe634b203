"""Test cases as files: a folder of ``test_*.mcs.yaml`` runs as tests, each on the PX4 fixtures."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml  # type: ignore[import-untyped]  # noqa: F401  # loaded once: in-process inner runs must not import it anew

DATA = Path(__file__).parent.parent / "data"

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
        (PAST + "speed: 3\n", "*unknown field*speed*"),
        (PAST.replace("fidelity: [low]", "fidelity: [lowest]"), "*fidelity*lowest*low, medium*"),
        (PAST.replace("type: box", "type: tree"), "*tree*"),
    ],
    ids=["negative-height", "missing-plan", "unknown-field", "bad-level", "unknown-shape"],
)
@pytest.mark.usefixtures("plan")
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
