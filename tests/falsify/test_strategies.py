"""Strategies: bounds, shrinking towards simple cases, a fresh simulation per example."""

from __future__ import annotations

import functools
import math
import operator

import pytest
from falsify_cart import CartScenario
from hypothesis import find, given, settings
from hypothesis import strategies as st

import multicosim as mcs
import multicosim.strategies as mst
from multicosim import FIDELITIES
from multicosim.mujoco import INTEGRATORS, SOLVERS, WorldConfig


@pytest.mark.parametrize(
    ("kwargs", "field", "match"),
    [
        ({"timestep": (0.01, 0.001)}, "timestep", "inverted"),
        ({"timestep": (0.0, 0.01)}, "timestep", r"inside \[0.0001, 0.1\]"),
        ({"timestep": (0.001, 0.5)}, "timestep", r"inside \[0.0001, 0.1\]"),
        ({"timestep": (0.001, 0.05)}, "timestep", "period"),
        ({"iterations": (0, 10)}, "iterations", r"integers .* inside \[1, 1000\]"),
        ({"iterations": (20, 10)}, "iterations", "inverted"),
        ({"iterations": (1.5, 10)}, "iterations", "integers"),
        ({"integrators": ["RK5"]}, "integrators", "drawn from"),
        ({"solvers": []}, "solvers", "non-empty"),
    ],
)
def test_world_config_bounds(kwargs: dict[str, object], field: str, match: str) -> None:
    with pytest.raises(mcs.ConfigurationError, match=match) as info:
        mst.world_configs(**kwargs)  # type: ignore[arg-type]
    assert info.value.field == field


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: mst.geofence_waypoints(radius=0.0), "radius"),
        (lambda: mst.geofence_waypoints(altitude=(50.0, 10.0)), "altitude"),
        (lambda: mst.geofence_waypoints(count=(0, 3)), "count"),
        (lambda: mst.geofence_waypoints(home=(91.0, 0.0, 0.0)), "home"),
        (lambda: mst.rover_missions(speed=(0.0, 5.0)), "speed"),
        (lambda: mst.rover_missions(speed=(1.0, 50.0)), "speed"),
        (lambda: mst.rover_missions(turn_angle=(0.0, 0.0)), "turn_angle"),
        (lambda: mst.noise_levels(-1.0), "noise"),
        (lambda: mst.fidelities(["ultra"]), "levels"),
    ],
)
def test_other_bounds(call: object, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        call()  # type: ignore[operator]
    assert info.value.field == field


def test_world_configs_reach_the_default_world_and_the_cheapest_bounds() -> None:
    # What the search may land on, not how Hypothesis gets there: the default world is among
    # the draws, and outside the default's range so are the cheapest settings.
    assert find(mst.world_configs(), lambda c: c == WorldConfig()) == WorldConfig()
    cheap = find(
        mst.world_configs(timestep=(0.004, 0.008), iterations=(5, 50)),
        lambda c: (c.timestep, c.iterations) == (0.008, 5),
    )
    assert (cheap.integrator, cheap.solver) in {(i, s) for i in INTEGRATORS for s in SOLVERS}


@given(config=mst.world_configs(timestep=(0.001, 0.005), iterations=(10, 20)))
def test_world_configs_respect_their_bounds(config: WorldConfig) -> None:
    assert 0.001 <= config.timestep <= 0.005
    assert 10 <= config.iterations <= 20


def test_waypoints_reach_one_above_home_at_the_lowest_altitude() -> None:
    home = (47.0, 8.0, 400.0)
    above = [(47.0, 8.0, 25.0)]
    assert find(mst.geofence_waypoints(home, altitude=(25.0, 50.0)), lambda w: w == above)


@given(mission=mst.geofence_waypoints((47.0, 8.0, 400.0), radius=100.0, count=(1, 3)))
def test_waypoints_stay_inside_the_geofence(mission: list[tuple[float, float, float]]) -> None:
    from multicosim.mujoco import geodetic_to_local

    assert 1 <= len(mission) <= 3
    for lat, lon, alt in mission:
        east, north, _ = geodetic_to_local((47.0, 8.0, 0.0), lat, lon, 0.0)
        assert math.hypot(east, north) <= 100.0 + 1e-6
        assert 10.0 <= alt <= 50.0


def test_rover_missions_noise_and_fidelities_reach_their_simplest_values() -> None:
    from multicosim.rover import Mission

    simple = Mission(speed=1.0, wait=0.0)
    assert find(mst.rover_missions(), lambda m: m == simple) == simple
    assert find(mst.noise_levels(0.5), lambda n: n == 0.0) == 0.0
    for level in FIDELITIES:
        assert find(mst.fidelities(), functools.partial(operator.eq, level)) == level


def test_target_robustness_outside_a_test_just_returns_it() -> None:
    assert mst.target_robustness(-0.25) == -0.25
    with pytest.raises(mcs.ConfigurationError):
        mst.target_robustness(math.nan)


SPEEDS: list[float] = []


@pytest.mark.fidelity("low")  # the noise-free cart: exact positions
@settings(max_examples=15, database=None)
@given(speed=st.floats(0.5, 3.0))
def test_a_fresh_simulation_per_example(
    mcs_fresh_simulation: mst.FreshSimulations, speed: float
) -> None:
    # The session-scoped fixture passes Hypothesis's function-scoped-fixture health check.
    with mcs_fresh_simulation(CartScenario) as cart:
        trajectory = cart.drive(speed, 10)
        assert cart.simulation.time == pytest.approx(9 * 0.05 + 19 * 0.05)
    assert cart.simulation.stopped  # stopped at the end of each example
    # Nothing carried over: each example's cart starts at 0.
    assert trajectory["x"][0] == 0.0
    assert trajectory["x"][-1] == pytest.approx(speed * 9 * 0.05)
    SPEEDS.append(speed)


def test_fresh_simulations_pass_fidelity_and_seed_when_accepted() -> None:
    seen: list[tuple[str, int]] = []

    def factory(fidelity: str, seed: int) -> CartScenario:
        seen.append((fidelity, seed))
        return CartScenario(fidelity, seed)

    with mst.FreshSimulations(fidelity="medium", seed=3)(factory) as cart:
        assert cart.fidelity == "medium"
    with mst.FreshSimulations()(lambda: CartScenario()) as cart:  # accepts neither
        assert cart.fidelity == "low"
    assert seen == [("medium", 3)]
    with pytest.raises(mcs.ConfigurationError):
        mst.FreshSimulations(fidelity="ultra")
