"""A case of PX4's suite must have one outcome on the built-in autopilot and on real PX4.

``tests/px4_agreement.py`` notes each case's outcome per autopilot and fails the run where
they differ, unless the module names the case a known or an open difference. Checked here on
a small suite of its own, run by pytest with that plugin.
"""

from __future__ import annotations

from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]
CONFTEST = f"""
import sys

sys.path.insert(0, {str(TESTS)!r})
from px4_agreement import Agreement


def pytest_configure(config):
    config.pluginmanager.register(Agreement(), "px4-agreement")
"""

SUITE = """
import pytest

KNOWN_DIFFERENCES = {"test_known": "navigator/mission_base.cpp: why PX4 v1.15 differs"}
FAILS_ON = {"test_differs": "sitl", "test_known": "sitl", "test_both_fail": "both"}


@pytest.fixture(params=["builtin", "sitl"])
def autopilot(request):
    return request.param


def _fly(name, autopilot):
    assert FAILS_ON.get(name) not in (autopilot, "both")


def test_agrees(autopilot):
    _fly("test_agrees", autopilot)


def test_differs(autopilot):
    _fly("test_differs", autopilot)


def test_known(autopilot):
    _fly("test_known", autopilot)


@pytest.mark.xfail(reason="fails on both", strict=True)
def test_both_fail(autopilot):
    _fly("test_both_fail", autopilot)
"""


def test_a_case_that_differs_fails_the_run_and_a_known_one_does_not(
    pytester: pytest.Pytester,
) -> None:
    pytester.makeconftest(CONFTEST)
    pytester.makepyfile(test_suite=SUITE)
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider", "-p", "no:randomly")
    result.stdout.fnmatch_lines(
        [
            "*built-in autopilot vs real PX4*",
            "test_agrees: built-in pass, real PX4 pass",
            "test_both_fail: built-in fail, real PX4 fail",
            "test_differs: built-in pass, real PX4 fail",
            "test_known: built-in pass, real PX4 fail (known: navigator/mission_base.cpp*",
            "DISAGREE test_differs: built-in pass, real PX4 fail",
        ]
    )
    assert "DISAGREE test_known" not in result.stdout.str()
    # test_differs fails on real PX4 anyway; the disagreement is what makes the run fail
    # even when every case's own result is as expected:
    assert result.ret == pytest.ExitCode.TESTS_FAILED


def test_a_disagreement_fails_a_run_whose_cases_all_passed_as_expected(
    pytester: pytest.Pytester,
) -> None:
    pytester.makeconftest(CONFTEST)
    suite = SUITE.replace(
        "def test_differs(autopilot):",
        '@pytest.mark.xfail(reason="real PX4 only")\ndef test_differs(autopilot):',
    ).replace('"test_known": "sitl", ', "")
    pytester.makepyfile(test_suite=suite)
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider", "-k", "differs or agrees")
    result.assert_outcomes(passed=2, xpassed=1, xfailed=1)
    result.stdout.fnmatch_lines(["DISAGREE test_differs: built-in pass, real PX4 fail"])
    assert result.ret == pytest.ExitCode.TESTS_FAILED


def test_the_run_judges_agreement_over_every_worker(pytester: pytest.Pytester) -> None:
    # With xdist, a case's two outcomes may come from two workers: the controller compares.
    pytester.makeconftest(CONFTEST)
    pytester.makepyfile(test_suite=SUITE)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-n", "2")
    result.stdout.fnmatch_lines(["DISAGREE test_differs: built-in pass, real PX4 fail"])
    assert "DISAGREE test_known" not in result.stdout.str()
    assert result.ret == pytest.ExitCode.TESTS_FAILED


def test_an_open_difference_is_listed_and_does_not_fail_the_run(pytester: pytest.Pytester) -> None:
    pytester.makeconftest(CONFTEST)
    suite = (
        SUITE.replace(
            "def test_differs(autopilot):",
            '@pytest.mark.xfail(reason="real PX4 only")\ndef test_differs(autopilot):',
        )
        + '\nOPEN_DIFFERENCES = {"test_differs": "measured: 0.26 m against 0.25 m"}\n'
    )
    pytester.makepyfile(test_suite=suite)
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider", "-k", "differs or agrees")
    result.stdout.fnmatch_lines(
        ["test_differs: built-in *, real PX4 fail (open: measured: 0.26 m*"]
    )
    assert "DISAGREE" not in result.stdout.str()
    assert result.ret == pytest.ExitCode.OK
