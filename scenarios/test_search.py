"""The falsification benchmark's problems, searched as a regression suite (a small part of it).

``bench/bench_search.py`` measures every optimizer over many seeds; here the default
optimizer must find each problem's rare violation within its budget, and a violation found
at low fidelity must be confirmed at medium::

    pytest scenarios/test_search.py --mcs-fidelity=low,medium
"""

from __future__ import annotations

import pytest
from search_problems import PROBLEMS

from multicosim.falsify import default_optimizer


@pytest.mark.fidelity("low")
@pytest.mark.parametrize("name", list(PROBLEMS))
def test_the_default_optimizer_finds_the_rare_violation(name: str, mcs_seed: int) -> None:
    problem = PROBLEMS[name]
    result = problem.search(seed=mcs_seed)
    assert result.optimizer == default_optimizer()
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx is not None
    assert cx.results["low"].evaluation.robustness < 0
    assert set(cx.example) == set(problem.space)
    # The search stops at its first violation: nothing is simulated after it.
    assert result.first_violation == result.first_confirmed == result.simulations


@pytest.mark.fidelity("medium")
def test_a_low_fidelity_violation_is_confirmed_at_medium(mcs_seed: int) -> None:
    # The turn overshoots more with physics (tyre slip, steering lag): what low fidelity
    # finds holds at medium.
    problem = PROBLEMS["rover-turn"]
    result = problem.search(seed=mcs_seed, levels=("low", "medium"))
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx is not None
    assert cx.failing_levels == ("low", "medium")
    medium = result.stats["medium"]
    assert medium.transferred == 1
    assert medium.runs == medium.tried >= 1
    # Medium fidelity ran only to confirm: every search sample ran at low.
    assert result.stats["low"].runs == result.simulations
    assert result.wall_time_alone is not None
