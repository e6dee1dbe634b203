"""The F-16 fixture library, through pytester (as a user's suite would use it)."""

from __future__ import annotations

import pytest

import multicosim.f16 as f16

SUITE = """
import pytest
from multicosim.f16 import F16Simulation, InitialState

@pytest.fixture
def f16_initial():
    return InitialState(roll=0.8, pitch=-1.2)

@pytest.mark.fidelity("low")
def test_recovers(f16_simulation, mcs_seed):
    assert isinstance(f16_simulation, F16Simulation)
    assert f16_simulation.seed == mcs_seed == 3
    flight = f16_simulation.fly()
    assert flight.samples[0].roll == 0.8
    assert flight.lowest.altitude > 1000
"""


@pytest.fixture
def inner(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> pytest.Pytester:
    """An inner session that names no AeroBench itself (none lies beside its root)."""
    monkeypatch.delenv(f16.AEROBENCH_ENV, raising=False)
    pytester.makepyfile(test_suite=SUITE)
    return pytester


def test_the_option_names_aerobench(inner: pytest.Pytester, aerobench: f16.AeroBench) -> None:
    result = inner.runpytest(f"--mcs-aerobench-dir={aerobench.root}", "--mcs-seed=3")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines([f"multicosim f16: AeroBench from {aerobench.root}"])


def test_the_ini_twin_and_the_environment_name_it(
    inner: pytest.Pytester, aerobench: f16.AeroBench, monkeypatch: pytest.MonkeyPatch
) -> None:
    inner.makeini(f"[pytest]\nmcs_aerobench_dir = {aerobench.root}\n")
    inner.runpytest("--mcs-seed=3").assert_outcomes(passed=1)
    inner.makeini("[pytest]\n")
    monkeypatch.setenv(f16.AEROBENCH_ENV, str(aerobench.code))
    inner.runpytest("--mcs-seed=3").assert_outcomes(passed=1)


def test_without_aerobench_the_tests_are_skipped_with_the_reason(inner: pytest.Pytester) -> None:
    result = inner.runpytest("--mcs-seed=3", "-rs")
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["*no AeroBench at *--mcs-aerobench-dir*"])


def test_a_named_directory_that_is_not_aerobench_is_an_error(inner: pytest.Pytester) -> None:
    result = inner.runpytest(f"--mcs-aerobench-dir={inner.path}", "--mcs-seed=3")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*ConfigurationError: directory=*missing: aerobench/*"])
