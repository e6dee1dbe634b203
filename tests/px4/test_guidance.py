"""Where the built-in autopilot aims on a mission leg: PX4 v1.15's crossing point."""

from __future__ import annotations

import math

import pytest

from multicosim.px4.autopilot.control import crossing_point

ORIGIN, TARGET = (0.0, 0.0), (0.0, 40.0, -10.0)  # a leg 40 m east
ACC = 2.0


def test_heading_for_the_waypoint_it_flies_straight_at_it_even_off_the_line() -> None:
    # 3 m south of the line, flying straight at the waypoint: no turn, no line to come back to.
    pos = [-3.0, 10.0, -10.0]
    to = (TARGET[0] - pos[0], TARGET[1] - pos[1])
    vel = [to[0] / math.hypot(*to) * 5.0, to[1] / math.hypot(*to) * 5.0, 0.0]
    assert crossing_point(pos, vel, ORIGIN, TARGET, ACC) == (TARGET[0], TARGET[1])


def test_turning_it_aims_at_the_line_five_metres_on() -> None:
    # After a corner, still flying north 3 m south of the line: it heads for the line.
    pos, vel = [-3.0, 10.0, -10.0], [5.0, 0.0, 0.0]
    north, east = crossing_point(pos, vel, ORIGIN, TARGET, ACC)
    assert north == pytest.approx(0.0)
    assert east == pytest.approx(10.0 + math.sqrt(5.0**2 - 3.0**2))  # L1 = max(2, 5) m


@pytest.mark.parametrize(
    ("pos", "vel"),
    [
        ([-1.0, 39.0, -10.0], [5.0, 0.0, 0.0]),  # within the acceptance radius
        ([-3.0, 10.0, -10.0], [0.1, 0.0, 0.0]),  # hardly moving
    ],
)
def test_near_the_waypoint_or_slow_it_aims_at_the_waypoint(
    pos: list[float], vel: list[float]
) -> None:
    assert crossing_point(pos, vel, ORIGIN, TARGET, ACC) == (TARGET[0], TARGET[1])
