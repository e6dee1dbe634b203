"""Wind on the PX4 scenario: a steady crosswind tilts a hovering vehicle by atan(drag / weight).

With real PX4 configured (MCS_PX4_BINARY) the same flight runs on it: it feels the wind
through our world only, and holds its position against it.
"""

from __future__ import annotations

import dataclasses
import math
import statistics

import pytest

import multicosim.px4 as px4
from multicosim.core.fidelity import check_fidelity
from multicosim.core.geo import GRAVITY, LocalProjection
from multicosim.physics import Wind
from multicosim.physics.wind import AIR_DENSITY
from multicosim.px4.scenario import default_world
from multicosim.quadrotor.airframe import NONE_IRIS

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
WIND = 8.0


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


def hover(simulation: px4.PX4Simulation) -> px4.MissionResult:
    """Straight up to 10 m over home and straight down again: it hovers in the wind."""
    config = px4.Configuration([wp(0, 0, 10), wp(0, 0.5, 10)], time_limit=120)
    result = simulation.firmware.send(config)
    assert result.completed, result.reason
    return result


@pytest.fixture
def px4_world(mcs_fidelity: str) -> px4.WorldConfig:
    """The fidelity's world in a steady wind from the east."""
    return dataclasses.replace(
        default_world(check_fidelity(mcs_fidelity)), wind=Wind(speed=WIND, direction=90.0)
    )


@pytest.mark.fidelity("medium")
def test_a_steady_crosswind_tilts_a_hovering_vehicle_by_drag_over_weight(
    px4_simulation: px4.PX4Simulation,
) -> None:
    result = hover(px4_simulation)
    drag = 0.5 * AIR_DENSITY * NONE_IRIS.drag_coefficient * NONE_IRIS.drag_area * WIND**2
    expected = math.degrees(math.atan(drag / (NONE_IRIS.mass * GRAVITY)))
    hovering = [
        s
        for s in result.trajectory
        if s.true_alt > 1.5 and math.hypot(s.vx, s.vy) < 0.15 and abs(s.vz) < 1.0
    ]
    assert len(hovering) > 40
    tilt = [math.degrees(math.acos(math.cos(s.roll) * math.cos(s.pitch))) for s in hovering]
    assert statistics.median(tilt) == pytest.approx(expected, abs=1.0)
    # Leaning into a wind from the east, whatever its heading: the thrust (body up) leans east.
    east = [
        math.sin(s.roll) * math.cos(s.yaw) - math.cos(s.roll) * math.sin(s.pitch) * math.sin(s.yaw)
        for s in hovering
    ]
    assert statistics.median(east) > 0
    # And it holds its position against the wind.
    drift = max(math.hypot(*PROJ.project(s.true_lat, s.true_lon)) for s in hovering)
    assert drift < 2.0


@pytest.mark.fidelity("low")
def test_the_point_mass_drifts_downwind_and_comes_back(
    px4_simulation: px4.PX4Simulation,
) -> None:
    result = hover(px4_simulation)
    easts = [PROJ.project(s.true_lat, s.true_lon)[1] for s in result.trajectory if s.true_alt > 1]
    # The wind from the east pushes it west; the autopilot's position loop holds it near home.
    assert min(easts) < -0.05
    assert max(abs(e) for e in easts) < 3.0
