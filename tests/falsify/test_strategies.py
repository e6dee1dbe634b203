"""Strategies: bounds, shrinking towards simple cases, a fresh simulation per example."""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable

import pytest
from falsify_cart import CartScenario
from hypothesis import find, given, settings
from hypothesis import strategies as st

import multicosim as mcs
import multicosim.rover.strategies as rover_st
import multicosim.search.strategies as mst
from multicosim import FIDELITIES
from multicosim.core.geo import LocalProjection
from multicosim.physics import INTEGRATORS, SOLVERS, WorldConfig
from multicosim.px4 import Configuration, Home
from multicosim.px4 import strategies as px4st


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
        (lambda: px4st.waypoints(distance=(-1.0, 10.0)), "distance"),
        (lambda: px4st.waypoints(altitude=(50.0, 10.0)), "altitude"),
        (lambda: px4st.missions(count=(0, 3)), "count"),
        (lambda: rover_st.missions(speed=(0.0, 5.0)), "speed"),
        (lambda: rover_st.missions(speed=(1.0, 50.0)), "speed"),
        (lambda: rover_st.missions(turn_angle=(0.0, 0.0)), "turn_angle"),
        (lambda: rover_st.sensor_noise(scale=(2.0, 1.0)), "scale"),
        (lambda: rover_st.world_configs(iterations=(0, 10)), "iterations"),
        (lambda: mst.noise_levels(-1.0), "noise"),
        (lambda: mst.fidelities(["ultra"]), "levels"),
    ],
)
def test_other_bounds(call: Callable[[], object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        call()
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


def test_waypoints_reach_the_lowest_altitude() -> None:
    points = px4st.waypoints(Home(47.0, 8.0, 400.0), altitude=(25.0, 50.0))
    assert find(points, lambda w: w.alt == 25.0).alt == 25.0


@given(config=px4st.missions(Home(47.0, 8.0, 400.0), count=(1, 3), distance=(0.0, 100.0)))
def test_waypoints_stay_within_their_distance(config: Configuration) -> None:
    assert 1 <= len(config.mission) <= 3
    for waypoint in config.mission:
        north, east = LocalProjection(47.0, 8.0).project(waypoint.lat, waypoint.lon)
        assert math.hypot(east, north) <= 100.0 + 0.05  # the coordinates are rounded
        assert 5.0 <= waypoint.alt <= 50.0


def test_rover_missions_noise_and_fidelities_reach_their_simplest_values() -> None:
    from multicosim.rover import Mission

    simple = find(rover_st.missions(speed=(1.0, 2.0)), lambda m: m.wait == 0.0 and m.speed == 1.0)
    assert isinstance(simple, Mission)
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
