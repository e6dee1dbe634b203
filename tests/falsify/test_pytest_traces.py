"""A failing @given test leaves the trace of its final, minimal example (plugin wiring).

The inner conftest is the wiring the pytest plugin needs (see ``WIRING``): it activates a
TestTrace around each test call and saves it in the failure report.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from multicosim.trace import falsifying_example, read_trace

HERE = Path(__file__).parent

WIRING = """
import re
from pathlib import Path

import pytest

from multicosim import trace
from multicosim.search.strategies import FreshSimulations

_trace_key = pytest.StashKey[trace.TestTrace]()


@pytest.fixture(scope="session")
def mcs_fresh_simulation():
    return FreshSimulations()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    callspec = getattr(item, "callspec", None)
    fidelity = callspec.params.get("mcs_fidelity", "low") if callspec else "low"
    session = trace.TestTrace(
        metadata={"test": item.nodeid, "seed": 0, "fidelity": fidelity, "backend": "process"}
    )
    item.stash[_trace_key] = session
    with trace.activate(session):
        return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    session = item.stash.get(_trace_key, None)
    if report.when == "call" and report.failed and session is not None:
        slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", item.nodeid).strip("_")
        example = trace.falsifying_example(call.excinfo.value) if call.excinfo else None
        saved = session.save(Path("artifacts") / slug, failing_example=example)
        report.sections.append(
            ("multicosim", "\\n".join(f"trace: {p}" for p in saved))
        )
    return report
"""

TEST = """
from hypothesis import given, settings, strategies as st

import multicosim.search.strategies as mst
from falsify_cart import PIT, CartScenario
from multicosim.search.requirements import Requirement

PIT_REQUIREMENT = Requirement(PIT)


@settings(max_examples=300, database=None, derandomize=True, deadline=None)
@given(speed=st.floats(0.0, 5.0), steps=st.integers(1, 100))
def test_never_rests_in_the_pit(mcs_fresh_simulation, speed, steps):
    with mcs_fresh_simulation(CartScenario) as cart:
        trajectory = cart.drive(speed, steps)
    mst.target_robustness(PIT_REQUIREMENT.evaluate(trajectory))
    PIT_REQUIREMENT.check(trajectory)


@settings(max_examples=20, database=None, derandomize=True, deadline=None)
@given(speed=st.floats(0.0, 5.0))
def test_stays_on_the_track(mcs_fresh_simulation, speed):
    with mcs_fresh_simulation(CartScenario) as cart:
        trajectory = cart.drive(speed, 10)
    Requirement("always (x >= 0)").check(trajectory)
"""


def test_a_failing_property_leaves_the_trace_of_its_minimal_example(
    pytester: pytest.Pytester,
) -> None:
    pytester.makeconftest(WIRING)
    pytester.makepyfile(falsify_cart=(HERE / "falsify_cart.py").read_text())
    pytester.makepyfile(test_pit=TEST)
    result = pytester.runpytest("-p", "no:cacheprovider", "-p", "no:multicosim")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(
        [
            "*requirement 'always ((v > 0.01) or (abs(x - 3.7) >= 0.1))' is violated*",
            "*Failing test case: test_never_rests_in_the_pit(*",
            "*trace: artifacts/test_pit.py_test_never_rests_in_the_pit/trace.mcap",
            "*trace: artifacts/test_pit.py_test_never_rests_in_the_pit/trace.png",
        ]
    )
    directory = pytester.path / "artifacts" / "test_pit.py_test_never_rests_in_the_pit"
    assert (directory / "trace.png").read_bytes().startswith(b"\x89PNG")
    trace = read_trace(directory / "trace.mcap")
    assert {"state", "cmd", "mcs/trajectory", "mcs/robustness"} <= set(trace.channels)
    example = trace.info["failing_example"]
    assert example.startswith("Failing test case: test_never_rests_in_the_pit(")
    assert "mcs_fresh_simulation=FreshSimulations()," in example
    # The trace is the final (minimal) example's: its trajectory is the one that was reported.
    speed = float(example.split("speed=")[1].split(",")[0])
    steps = int(example.split("steps=")[1].split(",")[0])
    resting = trace.topic("mcs/trajectory")[-1].data
    assert resting["v"] == 0.0
    assert resting["x"] == pytest.approx(speed * (steps - 1) * 0.05)
    assert float(trace.info["robustness"]) < 0
    assert trace.info["fidelity"] == "low"
    # Only the failing test saved anything.
    assert [p.name for p in (pytester.path / "artifacts").iterdir()] == [directory.name]


def test_falsifying_example_from_a_report_or_an_exception() -> None:
    text = (
        "E   AssertionError: boom\n"
        "E   Failing test case: test_x(\n"
        "E       speed=1.5,\n"
        "E       steps=3,\n"
        "E   )\n"
        "more\n"
    )
    assert falsifying_example(text) == "Failing test case: test_x(\n    speed=1.5,\n    steps=3,\n)"
    assert falsifying_example("Falsifying example: test_y(a=1)\n") == (
        "Falsifying example: test_y(a=1)"
    )
    assert falsifying_example("no example here") is None
    error = AssertionError("boom")
    assert falsifying_example(error) is None
    error.add_note("Failing test case: test_z(a=2)")
    assert falsifying_example(error) == "Failing test case: test_z(a=2)"


def test_falsifying_examples_of_an_exception_group() -> None:
    # Hypothesis reports several distinct failures of one test as an ExceptionGroup.
    first, second = AssertionError("one"), ValueError("two")
    first.add_note("Falsifying example: test_w(a=1)")
    second.add_note("Falsifying example: test_w(a=-1)")
    group = ExceptionGroup("Hypothesis found 2 distinct failures.", [first, second])
    assert falsifying_example(group) == (
        "Falsifying example: test_w(a=1)\nFalsifying example: test_w(a=-1)"
    )
    assert falsifying_example(ExceptionGroup("no examples", [ValueError("x")])) is None
    text = (
        "  | ExceptionGroup: Hypothesis found 2 distinct failures. (2 sub-exceptions)\n"
        "  +-+---------------- 1 ----------------\n"
        "    | AssertionError: one\n"
        "    | Falsifying example: test_w(\n"
        "    |     a=1,\n"
        "    | )\n"
    )
    assert falsifying_example(text) == "Falsifying example: test_w(\n    a=1,\n)"
