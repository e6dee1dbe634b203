"""Requirements: robustness values, worst time and values, bad input."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest

import multicosim as mcs
from multicosim.search.requirements import (
    FormulaError,
    Requirement,
    RequirementViolation,
    assert_satisfied,
    signals_of,
)

TIMES = [0.0, 1.0, 2.0, 3.0]


class Point(msgspec.Struct, frozen=True):
    time: float
    alt: float
    mode: str = "cruise"


def test_always_robustness_is_the_smallest_margin() -> None:
    evaluation = Requirement("always (alt >= 0)").evaluate(
        {"alt": [1.0, -0.5, 2.0, 0.25]}, times=TIMES
    )
    assert evaluation.robustness == pytest.approx(-0.5)
    assert evaluation.worst_time == 1.0
    assert evaluation.values == {"alt": -0.5}
    assert evaluation.predicate == "(alt)>=(0.0)"
    assert not evaluation.satisfied
    assert [v for _, v in evaluation.series] == pytest.approx([1.0, -0.5, 2.0, 0.25])


def test_a_violation_names_its_first_and_its_worst_instant() -> None:
    # Out below 0 from t=1 on, furthest out at t=3: the message names both instants.
    evaluation = Requirement("always (alt >= 0)").evaluate(
        {"alt": [1.0, -1.0, -0.5, -3.0]}, times=TIMES
    )
    assert evaluation.first_violation == 1.0
    assert evaluation.worst_time == 3.0
    text = evaluation.explain()
    assert "is violated: first violated at t=1 s; worst robustness -3 at t=3 s (alt=-3)" in text
    with pytest.raises(RequirementViolation, match="first violated at t=1 s; worst robustness"):
        Requirement("always (alt >= 0)").check({"alt": [1.0, -1.0, -0.5, -3.0]}, times=TIMES)
    holds = Requirement("always (alt >= -5)").evaluate({"alt": [1.0, -1.0]}, times=TIMES[:2])
    assert "holds: robustness 4 at t=1 s" in holds.explain()
    assert "violated" not in holds.explain()


def test_eventually_robustness_is_the_best_margin() -> None:
    evaluation = Requirement("eventually (alt >= 3)").evaluate(
        {"alt": [1.0, 2.5, 2.0, 0.0]}, times=TIMES
    )
    assert evaluation.robustness == pytest.approx(-0.5)
    assert evaluation.worst_time == 1.0


def test_time_bounds_are_seconds_in_dense_and_discrete_time() -> None:
    data = {"alt": [0.0, 1.0, 4.0, 5.0]}
    # Within the first second the best altitude is 1 (at t=1): robustness 1 - 3 = -2.
    for semantics in ("dense", "discrete"):
        req = Requirement("eventually[0:1] (alt >= 3)", semantics=semantics)
        assert req.robustness(data, times=TIMES) == pytest.approx(-2.0), semantics
    assert Requirement("eventually[0:2] (alt >= 3)").robustness(data, times=TIMES) == 1.0


def test_irregular_samples_are_fine_in_dense_time_only() -> None:
    data = {"alt": [1.0, 2.0, 3.0], "time": [0.0, 0.1, 5.0]}
    assert Requirement("always (alt > 0)").robustness(data) == pytest.approx(1.0)
    with pytest.raises(mcs.ConfigurationError, match="uniform sampling"):
        Requirement("always (alt > 0)", semantics="discrete").robustness(data)


def test_boolean_combination_and_arithmetic() -> None:
    req = Requirement("always ((v > 0.01) or (abs(x - 3.7) >= 0.1))")
    resting_in_pit = {"x": [0.0, 2.0, 3.65, 3.65], "v": [2.0, 2.0, 0.0, 0.0]}
    evaluation = req.evaluate(resting_in_pit, times=TIMES)
    assert evaluation.robustness == pytest.approx(-0.01)
    assert evaluation.worst_time == 2.0
    assert evaluation.values == {"v": 0.0, "x": 3.65}
    resting_outside = {"x": [0.0, 2.0, 4.0, 4.0], "v": [2.0, 2.0, 0.0, 0.0]}
    assert req.robustness(resting_outside, times=TIMES) == pytest.approx(0.2)


def test_a_sequence_of_structs_is_a_trajectory() -> None:
    samples = [Point(time=t, alt=a) for t, a in zip(TIMES, [3.0, 2.0, 1.5, 4.0], strict=True)]
    evaluation = Requirement("always (alt >= 2)").evaluate(samples)
    assert evaluation.robustness == pytest.approx(-0.5)
    assert evaluation.worst_time == 2.0
    # The non-numeric field is not a signal.
    assert set(signals_of(samples).columns) == {"alt"}


def test_a_structured_array_is_a_trajectory() -> None:
    # What fmpy.simulate_fmu and multicosim.fmi return: time, numbers, arrays, booleans.
    dtype = [("time", np.float64), ("h", np.float64), ("y", np.float64, (2,)), ("on", np.bool_)]
    result = np.array(
        [
            (0.0, 1.0, (0.0, 5.0), True),
            (1.0, -0.5, (1.0, 4.0), False),
            (2.0, 2.0, (2.0, 3.0), True),
        ],
        dtype=dtype,
    )
    signals = signals_of(result)
    assert list(signals.columns) == ["h", "y[0]", "y[1]", "on"]
    assert signals.times.tolist() == [0.0, 1.0, 2.0]
    assert Requirement("always (h >= 0)").evaluate(result).robustness == -0.5
    evaluation = Requirement("always (y1 >= 3.5)", derived={"y1": lambda s: s["y[1]"]})
    assert evaluation.evaluate(result).robustness == pytest.approx(-0.5)


def test_derived_signals() -> None:
    req = Requirement("always (dist <= 5)", derived={"dist": lambda s: np.hypot(s["x"], s["y"])})
    evaluation = req.evaluate({"x": [0.0, 3.0, 6.0], "y": [0.0, 4.0, 8.0]}, times=[0, 1, 2])
    assert evaluation.robustness == pytest.approx(-5.0)
    assert evaluation.values == {"dist": pytest.approx(10.0)}


def test_check_fails_with_robustness_worst_time_and_values() -> None:
    req = Requirement("always (alt >= 0)")
    with pytest.raises(RequirementViolation) as info:
        req.check({"alt": [1.0, -0.5, 2.0, 0.25]}, times=TIMES)
    message = str(info.value)
    assert "robustness -0.5" in message
    assert "t=1 s" in message
    assert "alt=-0.5" in message
    assert isinstance(info.value, AssertionError)
    assert info.value.evaluation.worst_time == 1.0
    assert assert_satisfied("always (alt >= 0)", {"alt": [1.0]}, times=[0.0]).robustness == 1.0


def test_zero_robustness_counts_as_satisfied() -> None:
    assert Requirement("always (alt >= 0)").check({"alt": [0.0, 1.0]}, times=[0, 1]).satisfied


@pytest.mark.parametrize(
    ("formula", "column", "reason"),
    [
        ("always (alt >= ", 14, "mismatched input '<EOF>'"),
        ("always (alt >= 0) )", 18, "extraneous input ')'"),
        ("always (alt >= #)", 15, "token recognition error"),
        ("alwayz alt > 0", 7, "a second formula starts at 'alt'"),
    ],
)
def test_a_formula_that_does_not_parse_points_at_the_position(
    formula: str, column: int, reason: str
) -> None:
    with pytest.raises(FormulaError) as info:
        Requirement(formula)
    error = info.value
    assert isinstance(error, mcs.ConfigurationError)
    assert (error.line, error.column) == (1, column)
    assert reason in str(error)
    # The message shows the formula with a caret under the offending column.
    lines = str(error).splitlines()
    assert lines[-1].index("^") - lines[-2].index(formula.strip()[0]) == column


def test_a_missing_signal_is_named() -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        Requirement("always (altitude >= 0)").evaluate({"alt": [1.0]}, times=[0.0])
    assert info.value.field == "signal"
    assert info.value.value == "altitude"
    assert "['alt']" in str(info.value)


@pytest.mark.parametrize(
    ("trajectory", "times", "match"),
    [
        ({"alt": []}, [], "at least one sample"),
        ([], None, "at least one sample"),
        ({"alt": [1.0, 2.0]}, [0.0, 0.0], "strictly increasing"),
        ({"alt": [1.0, 2.0]}, [0.0], "2 values"),
        ({"alt": [1.0, math.nan]}, [0.0, 1.0], "finite values"),
        ({"alt": [1.0]}, None, "sample times"),
        ("alt", None, "a mapping of signal name"),
    ],
)
def test_bad_trajectories(trajectory: object, times: list[float] | None, match: str) -> None:
    with pytest.raises(mcs.ConfigurationError, match=match):
        Requirement("always (alt >= 0)").evaluate(trajectory, times=times)


def test_bad_arguments() -> None:
    with pytest.raises(mcs.ConfigurationError, match="semantics"):
        Requirement("always (a > 0)", semantics="continuous")  # type: ignore[arg-type]
    with pytest.raises(mcs.ConfigurationError, match="non-empty"):
        Requirement("  ")
