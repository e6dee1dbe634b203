"""Multi-fidelity falsification on the cart: search low, confirm higher."""

from __future__ import annotations

from pathlib import Path

import pytest
from falsify_cart import PIT, run
from hypothesis import strategies as st

import multicosim as mcs
from multicosim.falsify import FalsificationResult, examples_to_first_violation, falsify
from multicosim.trace import read_trace

INPUTS = st.tuples(st.floats(0.0, 5.0), st.integers(1, 100))


def test_a_counterexample_found_at_low_fidelity_is_confirmed_above(tmp_path: Path) -> None:
    result = falsify(
        run,
        PIT,
        INPUTS,
        levels=("low", "medium", "high"),
        budget=300,
        seed=1,
        trace_dir=tmp_path,
    )
    assert result.falsified
    assert result.first_violation == 33
    counterexample = result.counterexample
    assert counterexample is not None
    speed, steps = counterexample.example
    # The cart comes to rest one driver period after the last command, inside the pit.
    assert abs(speed * (steps - 1) * 0.05 - 3.7) < 0.1
    assert list(counterexample.results) == ["low", "medium", "high"]
    assert counterexample.results["low"].falsified
    # The same input at every level: the low-level verdict carries over here.
    assert counterexample.failing_levels == ("low", "medium", "high")
    assert counterexample.highest_failing == "high"
    for level, outcome in counterexample.results.items():
        trace_path = outcome.traces[0]
        assert trace_path == tmp_path / level / "trace.mcap"
        trace = read_trace(trace_path)
        assert trace.info["fidelity"] == level
        assert trace.info["failing_example"] == repr(counterexample.example)
        assert {"state", "cmd", "mcs/trajectory", "mcs/robustness"} <= set(trace.channels)
    summary = result.summary()
    assert "first violation at example 33" in summary
    assert "high: FAILS" in summary
    with pytest.raises(AssertionError, match="minimal counterexample"):
        result.assert_holds()


def test_the_search_is_repeatable() -> None:
    a = falsify(run, PIT, INPUTS, levels=("low",), budget=100, seed=4, shrink=False)
    b = falsify(run, PIT, INPUTS, levels=("low",), budget=100, seed=4, shrink=False)
    assert (a.examples, a.first_violation, a.lowest) == (b.examples, b.first_violation, b.lowest)


def test_a_requirement_that_holds_is_not_falsified() -> None:
    result = falsify(run, "always (x >= -0.5)", INPUTS, levels=("low",), budget=40, seed=0)
    assert not result.falsified
    assert result.first_violation is None
    assert result.examples == 40
    assert result.lowest is not None
    assert result.lowest[0] >= 0.5
    assert "no violation found" in result.summary()
    result.assert_holds()


def test_statistics_over_searches() -> None:
    def outcome(first: int | None) -> FalsificationResult[object]:
        return FalsificationResult(
            requirement=PIT,
            levels=("low",),
            guided=True,
            budget=100,
            seed=0,
            examples=first or 100,
            first_violation=first,
            lowest=None,
            counterexample=None,
            wall_time=0.0,
        )

    stats = examples_to_first_violation([outcome(30), outcome(None), outcome(10), outcome(20)])
    assert stats == {
        "searches": 4,
        "found": 3,
        "median_found": 20.0,
        "mean_censored": (30 + 101 + 10 + 20) / 4,
        "max_found": 30,
    }


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"levels": ("ultra",)}, "levels"),
        ({"levels": ("low", "low")}, "levels"),
        ({"levels": ()}, "levels"),
        ({"budget": 0}, "budget"),
        ({"seed": -1}, "seed"),
    ],
)
def test_bad_arguments(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        falsify(run, PIT, INPUTS, **kwargs)  # type: ignore[arg-type]
    assert info.value.field == field
    with pytest.raises(mcs.ConfigurationError, match="Hypothesis strategy"):
        falsify(run, PIT, [(1.0, 2)])  # type: ignore[arg-type]
