"""Encounters drawn by Hypothesis are encounters by construction: their planned paths come
closest as drawn, and flown by the built-in autopilot at low fidelity they pass as planned."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

import multicosim as mcs
from multicosim import fleet
from multicosim.fleet import strategies as fleetst
from multicosim.quadrotor import NONE_IRIS

REACH = 2 * NONE_IRIS.radius  # the encounter measures separation between the bodies


@given(fleetst.encounters())
def test_planned_paths_come_closest_as_drawn_and_when(plan: fleetst.EncounterPlan) -> None:
    assert plan.separation(plan.time) == pytest.approx(plan.closest, abs=1e-6)
    steps = 400
    around = [plan.separation(2 * plan.time * i / steps) for i in range(steps + 1)]
    assert min(around) >= plan.closest - 1e-6
    # They start apart: the fleet refuses vehicles standing on each other.
    assert plan.separation(0.0) > 2.0


def _flown(plan: fleetst.EncounterPlan) -> fleet.Approach:
    with fleet.Fleet(plan.vehicles(), fidelity="low").start() as simulation:
        result = simulation.fly(plan.missions())
    assert result.completed, {n: r.reason for n, r in result.results.items()}
    assert not result.encounter.collisions
    return result.encounter.closest["alpha-bravo"]


LEVEL = [
    fleetst.EncounterPlan("head-on", 8.0, 12.0, 180.0, 5.0, 5.0),
    fleetst.EncounterPlan("crossing", 6.0, 12.0, 90.0, 5.0, 4.0),
    fleetst.EncounterPlan("overtaking", 6.0, 15.0, 0.0, 3.0, 6.0),
    fleetst.EncounterPlan("head-on", 5.0, 12.0, 180.0, 5.0, 5.0, vertical=5.0),
]


@pytest.mark.parametrize("plan", LEVEL, ids=lambda p: f"{p.kind}-{p.closest:g}m-{p.vertical:g}up")
def test_a_level_encounter_flies_as_planned(plan: fleetst.EncounterPlan) -> None:
    approach = _flown(plan)
    assert approach.separation == pytest.approx(plan.closest - REACH, abs=0.2)


def test_a_climb_through_the_ownships_level_passes_near_the_planned_closest_approach() -> None:
    plan = fleetst.EncounterPlan(
        "vertical", 6.0, 12.0, -60.0, 5.0, 5.0, altitude=20.0, vertical=10.0
    )
    approach = _flown(plan)
    # The climb is the autopilot's own (its climb rate, its acceptance radius at the
    # waypoint on the ownship's level), not the plan's even slope.
    assert approach.separation == pytest.approx(plan.closest - REACH, abs=2.0)
    assert approach.up == pytest.approx(plan.altitude, abs=2.0)


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    fleetst.encounters(
        kinds=("head-on", "crossing", "overtaking"), closest=(3.0, 15.0), time=(8.0, 12.0)
    )
)
def test_a_drawn_level_encounter_is_one_when_flown(plan: fleetst.EncounterPlan) -> None:
    assert _flown(plan).separation == pytest.approx(plan.closest - REACH, abs=0.5)


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: fleetst.encounters(kinds=("sideways",)), "kinds"),  # type: ignore[arg-type]
        (lambda: fleetst.encounters(speed=(3.0, 3.5)), "speed"),
        (lambda: fleetst.encounters(closest=(5.0, 1.0)), "closest"),
        (
            lambda: fleetst.EncounterPlan("crossing", 1.0, 10.0, 90.0, 5.0, 5.0, vertical=5.0),
            "closest",
        ),
        (lambda: fleetst.EncounterPlan("overtaking", 5.0, 10.0, 0.0, 5.0, 5.0), "intruder_speed"),
    ],
)
def test_impossible_encounters_are_refused_naming_the_field(make: object, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError, match=field):
        make()  # type: ignore[operator]
