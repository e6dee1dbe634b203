"""Hypothesis strategies for rover missions, sensor noise and world configurations.

```python
from hypothesis import given
from multicosim.rover.strategies import missions

@given(missions(speed=(0.5, 4.0)))
def test_mission(rover_simulation, mission): ...
```

Ranges are ``(low, high)`` tuples, as in
[`multicosim.search.strategies`][multicosim.search.strategies], checked when the strategy is built
(ConfigurationError names the argument). Every value a strategy draws is valid (it passes the types'
own validation), the bounds keep missions short enough for a test suite, and each strategy shrinks
towards the simple case: slow, no wait, no noise.
"""

from __future__ import annotations

import math
from typing import Any

from ..core.deps import require
from ..physics.config import INTEGRATORS, SOLVERS, WorldConfig
from ._messages import MAX_SPEED, MAX_STEERING, SENSOR_TOPICS, Mission
from ._vehicle import SensorNoise

require("hypothesis", "hypothesis")
from hypothesis import strategies as st  # noqa: E402 - after the dependency check, which names the extra

from ..search.strategies import Range, check_range, simple_first  # noqa: E402

__all__ = ["missions", "sensor_noise", "world_configs"]

# The size of a mission's turn (rad): 10 to 120 degrees.
_TURN_ANGLE = (math.radians(10.0), math.radians(120.0))


def _floats(bounds: tuple[float, float]) -> st.SearchStrategy[float]:
    return st.floats(*bounds, allow_nan=False, allow_infinity=False)


def missions(
    *,
    speed: Range = (0.5, MAX_SPEED),
    distance: Range = (0.5, 15.0),
    final_distance: Range = (0.5, 15.0),
    wait: Range = (0.0, 2.0),
    turn_angle: Range = _TURN_ANGLE,
    steering: Range = (0.2, MAX_STEERING),
    turn_left: bool | None = None,
    abort: bool = False,
) -> st.SearchStrategy[Mission]:
    """Missions with speed, distances, wait, turn angle (its size) and steering in the ranges.

    ``turn_left`` fixes the turn's direction (None: either); ``abort`` adds an ``abort_at``
    inside the mission's expected duration.
    """
    speeds = check_range("speed", speed, low=0.0, high=MAX_SPEED, low_open=True)
    distances = check_range("distance", distance, low=0.0, high=1e4, low_open=True)
    finals = check_range("final_distance", final_distance, low=0.0, high=1e4, low_open=True)
    waits = check_range("wait", wait, low=0.0, high=3600.0)
    angles = check_range("turn_angle", turn_angle, low=0.0, high=math.pi, low_open=True)
    steerings = check_range("steering", steering, low=0.0, high=MAX_STEERING, low_open=True)

    @st.composite
    def draw_mission(draw: Any) -> Mission:
        chosen_speed = draw(_floats(speeds))
        chosen_distance = draw(_floats(distances))
        chosen_final = draw(_floats(finals))
        angle = draw(_floats(angles))
        left = draw(st.booleans()) if turn_left is None else turn_left
        chosen_wait = draw(simple_first(waits[0], _floats(waits)))
        abort_at = None
        if abort:
            expected = chosen_wait + (chosen_distance + chosen_final) / chosen_speed + 2.0
            abort_at = draw(_floats((0.0, expected)))
        return Mission(
            speed=chosen_speed,
            wait=chosen_wait,
            distance=chosen_distance,
            turn_angle=angle if left else -angle,
            steering=draw(_floats(steerings)),
            final_distance=chosen_final,
            abort_at=abort_at,
        )

    return draw_mission()


def sensor_noise(*, scale: Range = (0.0, 3.0)) -> st.SearchStrategy[SensorNoise]:
    """Sensor noise from ``scale[0]`` to ``scale[1]`` times the realistic levels."""
    lo, hi = check_range("scale", scale, low=0.0, high=100.0)
    base = SensorNoise.realistic()
    return st.builds(
        SensorNoise,
        position=_floats((base.position * lo, base.position * hi)),
        magnetometer=_floats((base.magnetometer * lo, base.magnetometer * hi)),
        gyro=_floats((base.gyro * lo, base.gyro * hi)),
        accelerometer=_floats((base.accelerometer * lo, base.accelerometer * hi)),
        wheel_speed=_floats((base.wheel_speed * lo, base.wheel_speed * hi)),
    )


def world_configs(
    *,
    timestep: Range = (0.0005, 0.005),
    iterations: tuple[int, int] = (20, 200),
    remap: bool = False,
) -> st.SearchStrategy[WorldConfig]:
    """World configurations (the paper's simulator knobs), stable for the rover by default.

    The timestep divides the exchange period exactly; ``remap`` moves some sensors to
    other topics. Below about 20 solver iterations the CG and Newton solvers can let the
    rover's contacts fail (it rolls over): lower ``iterations`` to search for that.
    """
    steps = check_range("timestep", timestep, low=1e-5, high=0.02)
    it_lo, it_hi = check_range("iterations", iterations, low=1, high=1000, integer=True)

    @st.composite
    def draw_world(draw: Any) -> WorldConfig:
        chosen = draw(_floats(steps))
        period = chosen * draw(st.integers(1, max(1, round(0.02 / chosen))))
        topics: dict[str, str] = {}
        if remap:
            names = draw(st.lists(st.sampled_from(sorted(SENSOR_TOPICS)), unique=True))
            topics = {name: f"{SENSOR_TOPICS[name]}/raw" for name in names}
        return WorldConfig(
            timestep=chosen,
            integrator=draw(st.sampled_from(INTEGRATORS)),
            solver=draw(st.sampled_from(SOLVERS)),
            iterations=draw(st.integers(int(it_lo), int(it_hi))),
            period=period,
            sensor_topics=topics,
        )

    return draw_world()
