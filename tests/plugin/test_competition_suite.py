"""The UAV test competition's cases: a generator's output folder runs as a suite of tests."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml  # type: ignore[import-untyped]  # noqa: F401  # loaded once: in-process inner runs must not import it anew
from plugin_helpers import write_ini

from multicosim.px4.competition import read_case
from pytest_multicosim.cases import load_case
from pytest_multicosim.competition import from_mcs, to_mcs

EXAMPLES = Path(__file__).parents[2] / "scenarios" / "uav" / "competition"

# The example's flight (out 50 m east, 4 m south, back to land 10 m south of home) with a
# box 3 m north of where the outbound leg passes east 25 m, at north -2 m: 1 m when 2 m closer.
NEAR = (EXAMPLES / "two-blocks.yaml").read_text().replace("x: 3, y: 25", "x: 1, y: 25")
THROUGH = (EXAMPLES / "two-blocks.yaml").read_text().replace("x: 3, y: 25", "x: -4, y: 25")


@pytest.fixture
def out(pytester: pytest.Pytester) -> Path:
    """A generator's output folder: the example's cases, with its files beside them."""
    folder = pytester.path / "generated"
    shutil.copytree(EXAMPLES, folder)
    return folder


def _properties(junit: Path) -> dict[str, dict[str, str]]:
    tests = ET.parse(junit).getroot().iter("testcase")
    return {
        case.get("name", ""): {p.get("name", ""): p.get("value", "") for p in case.iter("property")}
        for case in tests
    }


def test_output_folder_runs_as_a_suite(pytester: pytest.Pytester, out: Path) -> None:
    junit = pytester.path / "junit.xml"
    result = pytester.runpytest(
        "-p", "no:randomly", "--mcs-competition=generated", "generated", f"--junitxml={junit}"
    )
    result.assert_outcomes(passed=3)
    # Named after their files, parametrized over the levels like any fidelity test.
    result.stdout.fnmatch_lines(
        [
            "*multicosim: the UAV test competition's scores*",
            "case*verdict*min_dist*point*sim s*wall s",
            "calm.yaml::test_calm[[]low[]] * pass * inf * 0 *",
            "two-blocks.yaml::test_two_blocks[[]low[]] * pass * 2.7* 0 *",
            "low: 3 flight(s), * s simulated in * s: * cases an hour on this machine, *"
            "within 500 s (7.2 an hour at its limit, *",
        ]
    )
    found = _properties(junit)["test_two_blocks[low]"]
    # The competition's distances, one per obstacle in the file's order, and its verdict.
    near, far = (float(d) for d in found["competition_distances"].split(", "))
    assert 2.5 < near < 3.0 < 9 < far
    assert float(found["competition_min_dist"]) == near
    assert (found["competition_point"], found["competition_verdict"]) == ("0", "pass")
    assert 35 < float(found["mcs_simulated_s"]) < 60


def test_closer_than_the_safe_distance_soft_fails(pytester: pytest.Pytester, out: Path) -> None:
    (out / "two-blocks.yaml").write_text(NEAR)
    (out / "collides.yaml").write_text(THROUGH)
    result = pytester.runpytest(
        "-p", "no:randomly", "--mcs-competition=generated", "generated", "-k", "blocks or coll"
    )
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(
        [
            "verdict: *soft fail: the vehicle came 0.* m from obstacles[[]0[]], within the "
            "competition's safe distance of 1.5 m (2 points)",
            "replay: *two-blocks.yaml::test_two_blocks[[]low[]]*",
        ]
    )
    result.stdout.fnmatch_lines(["verdict: *hard fail: the vehicle hit obstacles[[]0[]] (box) *"])
    result.stdout.fnmatch_lines(["*collides.yaml::test_collides[[]low[]] * hard fail * 5 *"])


def test_nothing_is_collected_unless_asked(pytester: pytest.Pytester, out: Path) -> None:
    # Without the option its folders' YAML is not ours.
    result = pytester.runpytest("-p", "no:randomly", "generated")
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED
    # With it, only files that look like a case, only in the folder named.
    (out / "notes.yaml").write_text("drone: only\n")
    (out / "broken.yaml").write_text("drone: [\n")
    pytester.makefile(".yaml", elsewhere=(EXAMPLES / "calm.yaml").read_text())
    result = pytester.runpytest("-p", "no:randomly", "--mcs-competition=generated", "--co", "-q")
    result.stdout.fnmatch_lines(["generated/calm.yaml::test_calm[[]low[]]"])
    result.stdout.no_fnmatch_line("*notes*")
    result.stdout.no_fnmatch_line("*elsewhere*")
    assert "3 tests collected" in result.stdout.str()


def test_ini_names_the_folder(pytester: pytest.Pytester, out: Path) -> None:
    write_ini(pytester, mcs_competition="generated")
    result = pytester.runpytest("-p", "no:randomly", "generated", "--co", "-q")
    assert "3 tests collected" in result.stdout.str()


def test_bad_case_is_a_collection_error(pytester: pytest.Pytester, out: Path) -> None:
    text = (out / "dogleg.yaml").read_text()
    (out / "dogleg.yaml").write_text(text.replace("mode: 3", "mode: 5"))
    result = pytester.runpytest("-p", "no:randomly", "--mcs-competition=generated", "generated")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(
        ["*dogleg.yaml: test.commands[[]0[]].mode='5 (Return)' is invalid: expected one command*"]
    )


def test_a_folder_that_is_not_there_is_a_usage_error(pytester: pytest.Pytester) -> None:
    result = pytester.runpytest("--mcs-competition=nowhere")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--mcs-competition: '*nowhere' is not a folder; allowed:*"])


def test_converted_case_means_the_same(pytester: pytest.Pytester, out: Path) -> None:
    case = to_mcs(out / "two-blocks.yaml", out / "test_two_blocks.mcs.yaml")
    assert case.score == "competition"
    assert load_case(out / "test_two_blocks.mcs.yaml") == case
    # Back again: the same plan, parameters and obstacles.
    from_mcs(out / "test_two_blocks.mcs.yaml", out / "back.yaml")
    assert read_case(out / "back.yaml") == read_case(out / "two-blocks.yaml")
    # Our file flies and is scored as the competition's.
    junit = pytester.path / "junit.xml"
    result = pytester.runpytest("-p", "no:randomly", "generated", f"--junitxml={junit}")
    result.assert_outcomes(passed=1)
    found = _properties(junit)["test_two_blocks[low]"]
    assert 2.5 < float(found["competition_min_dist"]) < 3.0
