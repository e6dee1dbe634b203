"""The falsification benchmark's problems, searched as a regression suite (a small part of it).

``bench/bench_search.py`` measures every optimizer over many seeds; here the default
optimizer must find each problem's rare violation within its budget, a violation found at
low fidelity must be confirmed at medium, and (with a real PX4 configured:
``--mcs-px4-binary`` or ``MCS_PX4_BINARY``) on real PX4 SITL::

    pytest scenarios/test_search.py --mcs-fidelity=low,medium
"""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest
from search_problems import PROBLEMS

import multicosim.px4 as px4
from multicosim.search.falsify import default_optimizer
from pytest_multicosim.px4 import RealPX4


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


@pytest.mark.fidelity("medium")
def test_a_violation_confirmed_at_medium_is_confirmed_on_real_px4(
    px4_sitl: RealPX4, mcs_seed: int
) -> None:
    # Search at low with the built-in autopilot, confirm at medium, then fly it on real PX4.
    geofence = PROBLEMS["px4-geofence"]
    sitl = px4_sitl.sitl()
    flights: list[tuple[str, px4.SITL | None]] = []

    def simulate(sample: Any, fidelity: str, seed: int, firmware: px4.SITL | None = None) -> Any:
        flights.append((fidelity, firmware))
        return geofence.simulate(sample, fidelity, seed, firmware=firmware)

    problem = dataclasses.replace(geofence, simulate=simulate)
    result = problem.search(seed=mcs_seed, levels=problem.levels(sitl))
    assert result.levels == ("low", "medium", px4.SITL_LEVEL)
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx is not None
    assert cx.failing_levels == ("low", "medium", px4.SITL_LEVEL)
    assert cx.results[px4.SITL_LEVEL].evaluation.robustness < 0
    medium, real = result.stats["medium"], result.stats[px4.SITL_LEVEL]
    # Every violation medium confirmed went on to real PX4; the last one held there too.
    assert real.tried == medium.transferred == real.runs >= 1
    assert real.transferred == 1
    assert result.transfer_rates[px4.SITL_LEVEL] == 1 / real.tried
    # Real PX4 flew exactly the real level's runs, on the MuJoCo world (medium fidelity).
    assert [f for f in flights if f[1] is not None] == [("medium", sitl)] * real.runs


@pytest.mark.fidelity("medium")
def test_two_aircraft_lose_separation_on_real_px4_flying_both(
    px4_sitl: RealPX4, mcs_seed: int
) -> None:
    # Searched at low with the built-in autopilot flying both, confirmed at medium, then
    # flown with two real PX4 instances in one world.
    problem = PROBLEMS["px4-separation"]
    result = problem.search(seed=mcs_seed, levels=problem.levels(px4_sitl.sitl()))
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx is not None
    assert cx.failing_levels == ("low", "medium", px4.SITL_LEVEL)
    assert cx.results[px4.SITL_LEVEL].evaluation.robustness < 0
    real = result.stats[px4.SITL_LEVEL]
    assert real.transferred == 1
    assert real.runs == real.tried >= 1
