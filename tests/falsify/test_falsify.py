"""Falsification on the cart: optimizers, spaces, levels, multi-fidelity, progress."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest
from falsify_cart import PIT, run
from hypothesis import strategies as st

import multicosim as mcs
from multicosim.search.falsify import (
    OPTIMIZERS,
    Choice,
    FalsificationResult,
    HypothesisSearch,
    Integer,
    Level,
    Real,
    falsify,
    first_violation_statistics,
)
from multicosim.trace import read_trace

# About 1 % of this space stops the cart in the pit.
SPACE = {"speed": (0.0, 5.0), "steps": Integer(1, 100)}


def is_pit(speed: float, steps: int) -> bool:
    """Where the cart comes to rest (one driver period after the last command) is the pit."""
    return abs(speed * (steps - 1) * 0.05 - 3.7) < 0.1


class Scripted:
    """An ask/tell optimizer that proposes ``samples`` in turn and keeps what it is told."""

    def __init__(self, samples: list[dict[str, Any]]) -> None:
        self.samples = list(samples)
        self.told: list[tuple[dict[str, Any], float]] = []

    def ask(self) -> dict[str, Any]:
        return self.samples[len(self.told) % len(self.samples)]

    def tell(self, asked: dict[str, Any], robustness: float) -> None:
        self.told.append((asked, robustness))


IN_PIT = {"speed": 1.0, "steps": 75}  # rests at 3.7 m
SHORT = {"speed": 1.0, "steps": 10}  # rests at 0.45 m


def test_each_optimizer_finds_the_pit_and_every_level_confirms_it() -> None:
    for optimizer in OPTIMIZERS:
        result = falsify(run, PIT, SPACE, optimizer=optimizer, budget=300, seed=1)
        assert result.falsified, (optimizer, result.summary())
        cx = result.counterexample
        assert cx is not None
        assert is_pit(cx.example["speed"], cx.example["steps"]), optimizer
        assert isinstance(cx.example["steps"], int)
        assert cx.found_at == "low"
        assert cx.failing_levels == ("low", "medium")
        assert result.first_violation is not None
        assert result.first_confirmed is not None
        assert result.first_violation <= result.first_confirmed <= result.simulations
        # Hypothesis shrinks past the first counterexample; the others stop there.
        if optimizer != "hypothesis":
            assert result.first_confirmed == result.simulations
        assert result.stats["medium"].tried >= 1
        assert result.transfer_rates["medium"] == 1.0  # the pit is the same at medium


@pytest.mark.parametrize("optimizer", OPTIMIZERS)
def test_a_seed_repeats_the_search_exactly(optimizer: str) -> None:
    a = falsify(run, PIT, SPACE, optimizer=optimizer, budget=60, seed=3, levels="low")
    b = falsify(run, PIT, SPACE, optimizer=optimizer, budget=60, seed=3, levels="low")
    assert [(t.sample, t.robustness) for t in a.trials] == [
        (t.sample, t.robustness) for t in b.trials
    ]
    assert a.first_violation == b.first_violation
    c = falsify(run, PIT, SPACE, optimizer=optimizer, budget=60, seed=4, levels="low")
    assert [t.sample for t in c.trials] != [t.sample for t in a.trials]


def test_a_requirement_that_holds_spends_the_budget() -> None:
    result = falsify(run, "always (x >= -0.5)", SPACE, optimizer="random", budget=25)
    assert not result.falsified
    assert result.first_violation is None
    assert result.simulations == len(result.trials) == 25
    assert result.lowest is not None
    assert result.lowest[0] >= 0.5
    assert "no confirmed violation" in result.summary()
    assert "25 simulations and 0 confirmations at medium, in " in result.summary()
    result.assert_holds()
    # One level: nothing is confirmed, so the summary counts no confirmations.
    alone = falsify(run, "always (x >= -0.5)", SPACE, optimizer="random", budget=5, levels="low")
    assert "budget 5): 5 simulations, in " in alone.summary()
    assert "confirmations" not in alone.summary()


def test_the_counterexample_leaves_a_trace_per_level(tmp_path: Path) -> None:
    result = falsify(
        run,
        PIT,
        SPACE,
        optimizer=Scripted([SHORT, IN_PIT]),
        levels=("low", "medium", "high"),
        trace_dir=tmp_path,
    )
    assert result.first_violation == result.first_confirmed == 2
    cx = result.counterexample
    assert cx is not None
    assert cx.example == IN_PIT
    assert list(cx.results) == ["low", "medium", "high"]
    assert cx.highest_failing == "high"
    for level, outcome in cx.results.items():
        assert outcome.traces[0] == tmp_path / "sample-00002" / level / "trace.mcap"
        trace = read_trace(outcome.traces[0])
        assert trace.info["fidelity"] == level
        assert {"state", "cmd", "mcs/trajectory", "mcs/robustness"} <= set(trace.channels)
    assert not (tmp_path / "sample-00001").exists()  # the first sample held
    summary = result.summary()
    # Two search samples, the second confirmed at medium and high.
    assert "2 simulations and 2 confirmations at medium, high, in " in summary
    assert "high: FAILS" in summary
    assert "lowest fidelity that falsifies: low" in summary
    with pytest.raises(AssertionError, match="counterexample"):
        result.assert_holds()


def shifted_cart(sample: Any, fidelity: str, seed: int) -> dict[str, list[float]]:
    """A 'higher level' whose cart rests 0.3 m further: the low pit is not its pit."""
    columns = run(sample, "low", seed)
    return {**columns, "x": [x + 0.3 for x in columns["x"]]}


def test_a_violation_that_does_not_transfer_is_told_as_the_higher_level_said() -> None:
    optimizer = Scripted([IN_PIT, SHORT])
    result = falsify(
        run,
        PIT,
        SPACE,
        optimizer=optimizer,
        budget=4,
        levels=("low", Level("shifted", shifted_cart)),
    )
    assert not result.falsified
    assert result.first_violation == 1  # found at low...
    stats = result.stats["shifted"]
    assert (stats.tried, stats.transferred) == (2, 0)  # ...twice, and never confirmed
    assert result.transfer_rates == {"shifted": 0.0}
    # The optimizer was told what the higher level measured, not the low violation.
    low_pit = [t.robustness for t in result.trials if t.level == "low" and t.sample == IN_PIT]
    shifted = [t.robustness for t in result.trials if t.level == "shifted"]
    assert low_pit[0] < 0 < shifted[0]
    sample, told = optimizer.told[0]
    assert sample == IN_PIT
    assert told == pytest.approx(shifted[0])
    assert "0/2 violations from below transferred" in result.summary()


def test_a_level_can_be_a_simulate_function_of_its_own() -> None:
    calls: list[str] = []

    def firmware_in_the_loop(sample: Any, fidelity: str, seed: int) -> dict[str, list[float]]:
        calls.append(fidelity)
        return run(sample, "low", seed)

    result = falsify(
        run, PIT, SPACE, optimizer=Scripted([IN_PIT]), levels=("low", firmware_in_the_loop)
    )
    assert result.levels == ("low", "firmware_in_the_loop")
    assert calls == ["firmware_in_the_loop"]
    assert result.counterexample is not None
    assert result.counterexample.failing_levels == ("low", "firmware_in_the_loop")
    assert result.wall_time_alone is not None


def coarse_cart(sample: Any, fidelity: str, seed: int) -> dict[str, list[float]]:
    """A cheap level that misses the pit entirely."""
    columns = run(sample, "low", seed)
    return {**columns, "x": [0.0 for _ in columns["x"]]}


def test_the_fidelity_in_the_space_and_the_lowest_level_that_still_falsifies() -> None:
    seen: list[tuple[Any, str]] = []

    def recorded(sample: Any, fidelity: str, seed: int) -> dict[str, list[float]]:
        seen.append((dict(sample), fidelity))
        return run(sample, fidelity, seed)

    space = {**SPACE, "fidelity": Choice("low", "medium")}
    result = falsify(recorded, PIT, space, optimizer=Scripted([{**IN_PIT, "fidelity": "medium"}]))
    # Found at medium, the top level; re-run below, where it still fails.
    assert seen == [(IN_PIT, "medium"), (IN_PIT, "low")]
    cx = result.counterexample
    assert cx is not None
    assert cx.found_at == "medium"
    assert cx.lowest_failing == "low"

    levels = (Level("coarse", coarse_cart), "low")
    space = {**SPACE, "fidelity": Choice("coarse", "low")}
    result = falsify(
        run, PIT, space, optimizer=Scripted([{**IN_PIT, "fidelity": "low"}]), levels=levels
    )
    assert result.counterexample is not None
    assert result.counterexample.failing_levels == ("low",)
    assert result.counterexample.lowest_failing == "low"


def test_integer_and_choice_dimensions_reach_the_simulation_as_such() -> None:
    worlds = ("calm", "windy")
    seen: list[dict[str, Any]] = []

    def simulate(sample: Mapping[str, Any], fidelity: str, seed: int) -> dict[str, list[float]]:
        seen.append(dict(sample))
        return run(sample, fidelity, seed)

    space = {
        "speed": Real(0.5, 5.0, log=True),
        "steps": Integer(1, 100),
        "world": Choice(*worlds),
    }
    for optimizer in ("tpe", "lhs", "hypothesis", "taliro-random"):
        seen.clear()
        falsify(simulate, PIT, space, optimizer=optimizer, budget=15, levels="low")
        assert seen, optimizer
        for sample in seen:
            assert 0.5 <= sample["speed"] <= 5.0
            assert isinstance(sample["steps"], int)
            assert 1 <= sample["steps"] <= 100
            assert sample["world"] in worlds


def test_a_hypothesis_strategy_is_searched_and_shrunk() -> None:
    inputs = st.tuples(st.floats(0.0, 5.0), st.integers(1, 100))
    result = falsify(run, PIT, inputs, optimizer="hypothesis", budget=300, seed=1)
    assert result.counterexample is not None
    speed, steps = result.counterexample.example
    assert is_pit(speed, steps)
    unshrunk = falsify(
        run, PIT, inputs, optimizer=HypothesisSearch(shrink=False), budget=300, seed=1
    )
    # Without shrinking the search ends at its first confirmed violation; with it, it goes on.
    assert unshrunk.counterexample is not None
    assert unshrunk.simulations == unshrunk.first_confirmed
    assert result.first_confirmed is not None
    assert result.simulations > result.first_confirmed


def test_optimizer_objects_of_optuna_and_psy_taliro() -> None:
    import optuna
    from staliro.optimizers import DualAnnealing

    for optimizer in (optuna.samplers.TPESampler(seed=2), DualAnnealing()):
        result = falsify(run, PIT, SPACE, optimizer=optimizer, budget=300, levels="low")
        assert result.falsified, result.summary()
        assert result.optimizer == type(optimizer).__name__


def test_progress_bar_on_request_and_quiet_otherwise(capsys: pytest.CaptureFixture[str]) -> None:
    falsify(run, PIT, SPACE, optimizer="random", budget=5, levels="low", progress=True)
    err = capsys.readouterr().err
    assert "falsify [random]" in err
    assert "best robustness" in err
    falsify(run, PIT, SPACE, optimizer="random", budget=5, levels="low")  # stderr: no terminal
    assert capsys.readouterr().err == ""


def test_statistics_over_searches() -> None:
    def outcome(first: int | None) -> FalsificationResult:
        return FalsificationResult(
            requirement=PIT,
            optimizer="random",
            levels=("low",),
            budget=100,
            seed=0,
            simulations=first or 100,
            first_violation=first,
            first_confirmed=first,
            lowest=None,
            counterexample=None,
            trials=(),
            stats={},
            wall_time=0.0,
        )

    stats = first_violation_statistics([outcome(30), outcome(None), outcome(10), outcome(20)])
    assert stats == {
        "searches": 4,
        "found": 3,
        "success_rate": 0.75,
        "median": 25.0,  # of 10, 20, 30 and 101 (the search that found none)
        "mean_censored": (30 + 101 + 10 + 20) / 4,
    }


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"levels": ("ultra",)}, "levels"),
        ({"levels": ("low", "low")}, "levels"),
        ({"levels": ()}, "levels"),
        ({"budget": 0}, "budget"),
        ({"seed": -1}, "seed"),
        ({"optimizer": "simplex"}, "optimizer"),
        ({"optimizer": object()}, "optimizer"),
        ({"space": {}}, "space"),
        ({"space": {"speed": (5.0, 1.0)}}, "space['speed']"),
        ({"space": {"speed": "fast"}}, "space['speed']"),
        ({"space": {"speed": (0.0, 1.0), "fidelity": Choice("low", "high")}}, "space['fidelity']"),
        ({"space": st.floats(), "optimizer": "tpe"}, "optimizer"),
        ({"space": [(1.0, 2)]}, "space"),
    ],
)
def test_bad_arguments_are_refused_before_anything_runs(kwargs: dict[str, Any], field: str) -> None:
    def never(sample: Any, fidelity: str, seed: int) -> object:
        raise AssertionError("must not run")

    arguments: dict[str, Any] = {"space": SPACE, **kwargs}
    space = arguments.pop("space")
    with pytest.raises(mcs.ConfigurationError) as info:
        falsify(never, PIT, space, **arguments)
    assert info.value.field == field


def test_dimensions_check_their_bounds() -> None:
    with pytest.raises(mcs.ConfigurationError):
        Real(1.0, 1.0)
    with pytest.raises(mcs.ConfigurationError):
        Real(0.0, 1.0, log=True)
    with pytest.raises(mcs.ConfigurationError):
        Integer(3, 2)
    with pytest.raises(mcs.ConfigurationError):
        Integer(1.5, 2)  # type: ignore[arg-type]
    with pytest.raises(mcs.ConfigurationError):
        Choice()


def test_a_run_of_another_shape_is_refused() -> None:
    def two_arguments(sample: Any, fidelity: str) -> object:
        raise AssertionError("must not run")

    with pytest.raises(mcs.ConfigurationError, match=r"simulate\(sample, fidelity, seed\)"):
        falsify(two_arguments, PIT, SPACE)  # type: ignore[arg-type]
