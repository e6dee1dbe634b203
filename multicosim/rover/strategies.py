"""Hypothesis strategies for rover missions and world configurations.

::

    from hypothesis import given
    from multicosim.rover.strategies import missions

    @given(missions(max_speed=4.0))
    def test_mission(rover_simulation, mission): ...

Every value a strategy draws is valid (it passes the types' own validation), and the
bounds keep missions short enough for a test suite.
"""

from __future__ import annotations

import math
from typing import Any

from .._deps import require
from ..mujoco._config import INTEGRATORS, SOLVERS, WorldConfig
from ._messages import MAX_SPEED, MAX_STEERING, SENSOR_TOPICS, Mission
from ._vehicle import SensorNoise

require("hypothesis", "hypothesis")
from hypothesis import strategies as st  # noqa: E402 - after the check, which names the extra

__all__ = ["missions", "sensor_noise", "world_configs"]


def _floats(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


@st.composite
def missions(
    draw: Any,
    *,
    min_speed: float = 0.5,
    max_speed: float = MAX_SPEED,
    max_distance: float = 15.0,
    max_wait: float = 2.0,
    min_turn_angle: float = math.radians(10.0),
    max_turn_angle: float = math.radians(120.0),
    turn_left: bool | None = None,
    abort: bool = False,
) -> Mission:
    """Missions with speeds, distances and turn angles in the given ranges.

    ``turn_left`` fixes the turn's direction (None: either); ``abort`` adds an ``abort_at``
    inside the mission's expected duration.
    """
    speed = draw(_floats(min_speed, max_speed))
    distance = draw(_floats(0.5, max_distance))
    final_distance = draw(_floats(0.5, max_distance))
    angle = draw(_floats(min_turn_angle, max_turn_angle))
    left = draw(st.booleans()) if turn_left is None else turn_left
    wait = draw(_floats(0.0, max_wait))
    abort_at = None
    if abort:
        expected = wait + (distance + final_distance) / speed + 2.0
        abort_at = draw(_floats(0.0, expected))
    return Mission(
        speed=speed,
        wait=wait,
        distance=distance,
        turn_angle=angle if left else -angle,
        steering=draw(_floats(0.2, MAX_STEERING)),
        final_distance=final_distance,
        abort_at=abort_at,
    )


def sensor_noise(*, max_scale: float = 3.0) -> st.SearchStrategy[SensorNoise]:
    """Sensor noise from ideal up to ``max_scale`` times the realistic levels."""
    base = SensorNoise.realistic()
    return st.builds(
        SensorNoise,
        position=_floats(0.0, base.position * max_scale),
        magnetometer=_floats(0.0, base.magnetometer * max_scale),
        gyro=_floats(0.0, base.gyro * max_scale),
        accelerometer=_floats(0.0, base.accelerometer * max_scale),
        wheel_speed=_floats(0.0, base.wheel_speed * max_scale),
    )


@st.composite
def world_configs(
    draw: Any,
    *,
    min_timestep: float = 0.0005,
    max_timestep: float = 0.005,
    min_iterations: int = 20,
    max_iterations: int = 200,
    remap: bool = False,
) -> WorldConfig:
    """World configurations (the paper's simulator knobs), stable for the rover by default.

    The timestep divides the exchange period exactly; ``remap`` moves some sensors to
    other topics. Below about 20 solver iterations the CG and Newton solvers can let the
    rover's contacts fail (it rolls over): lower ``min_iterations`` to search for that.
    """
    timestep = draw(_floats(min_timestep, max_timestep))
    period = timestep * draw(st.integers(1, max(1, round(0.02 / timestep))))
    topics: dict[str, str] = {}
    if remap:
        names = draw(st.lists(st.sampled_from(sorted(SENSOR_TOPICS)), unique=True))
        topics = {name: f"{SENSOR_TOPICS[name]}/raw" for name in names}
    return WorldConfig(
        timestep=timestep,
        integrator=draw(st.sampled_from(INTEGRATORS)),
        solver=draw(st.sampled_from(SOLVERS)),
        iterations=draw(st.integers(min_iterations, max_iterations)),
        period=period,
        sensor_topics=topics,
    )
