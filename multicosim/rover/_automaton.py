"""The rover's finite-state automaton: pure mission logic, no clock and no topics.

Follows the reference rover controller: wait, drive straight, turn with a fixed steering
angle until the heading has changed by the mission's angle, drive straight again, stop.
An abort stops it from any state; a turn or a mission that takes too long times out.
It decides on what it observes (sensed position, heading, speed), never on ground truth.
"""

from __future__ import annotations

import dataclasses
import enum
import math

from ._messages import Command, Mission

__all__ = ["TERMINAL", "Automaton", "Observation", "State"]


class State(enum.StrEnum):
    """Automaton states; the last three are terminal."""

    WAIT = "wait"
    DRIVE = "drive"
    TURN = "turn"
    DRIVE_AGAIN = "drive_again"
    DONE = "done"
    ABORTED = "aborted"
    TIMED_OUT = "timed_out"


TERMINAL = frozenset({State.DONE, State.ABORTED, State.TIMED_OUT})

# Below this speed on the final approach the rover creeps to the end point instead of
# following the braking curve to zero (which it would reach only asymptotically).
CREEP_SPEED = 0.25


@dataclasses.dataclass(frozen=True, slots=True)
class Observation:
    """What the controller knows at one instant (from its sensors)."""

    time: float
    x: float
    y: float
    heading: float
    speed: float


def _wrap(angle: float) -> float:
    return math.remainder(angle, math.tau)


class Automaton:
    """Decides a command per observation; ``state`` and ``reason`` say where it is and why."""

    def __init__(self, mission: Mission, start_time: float) -> None:
        self.mission = mission
        self.state = State.WAIT
        self.reason = ""
        self.start_time = start_time
        self._entered = start_time
        self._origin = (0.0, 0.0)
        self._turned = 0.0
        self._last_heading = 0.0
        self._direction = 1.0 if mission.turn_angle > 0 else -1.0

    @property
    def terminal(self) -> bool:
        """True once the automaton has stopped (done, aborted or timed out)."""
        return self.state in TERMINAL

    @property
    def completed(self) -> bool:
        """True if the whole plan was driven."""
        return self.state is State.DONE

    def _enter(self, state: State, obs: Observation, reason: str = "") -> None:
        self.state = state
        self._entered = obs.time
        self._origin = (obs.x, obs.y)
        self._last_heading = obs.heading
        self._turned = 0.0
        if reason:
            self.reason = reason

    def _distance(self, obs: Observation) -> float:
        return math.hypot(obs.x - self._origin[0], obs.y - self._origin[1])

    def update(self, obs: Observation, abort: str | None = None) -> Command:
        """Advance on ``obs`` (``abort``: the reason of a pending abort) and return the command."""
        m = self.mission
        if not self.terminal:
            if abort is not None:
                self._enter(State.ABORTED, obs, f"aborted: {abort}")
            elif obs.time - self.start_time >= m.timeout:
                self._enter(State.TIMED_OUT, obs, f"mission timeout ({m.timeout:g} s)")
        # Transitions can cascade within one instant (a zero wait, a zero distance).
        for _ in range(len(State)):
            before = self.state
            self._transition(obs)
            if self.state is before:
                break
        return self._command(obs)

    def _transition(self, obs: Observation) -> None:
        m = self.mission
        state = self.state
        if state is State.WAIT:
            if obs.time - self._entered >= m.wait:
                self._enter(State.DRIVE, obs)
        elif state is State.DRIVE:
            if self._distance(obs) >= m.distance:
                self._enter(State.TURN, obs)
        elif state is State.TURN:
            # Accumulate heading changes so turns beyond +-180 degrees unwrap correctly.
            self._turned += _wrap(obs.heading - self._last_heading)
            self._last_heading = obs.heading
            if self._turned * self._direction >= abs(m.turn_angle):
                self._enter(State.DRIVE_AGAIN, obs)
            elif obs.time - self._entered >= m.turn_timeout:
                self._enter(State.TIMED_OUT, obs, f"turn timeout ({m.turn_timeout:g} s)")
        elif state is State.DRIVE_AGAIN and self._distance(obs) >= m.final_distance:
            self._enter(State.DONE, obs, "completed")

    def _command(self, obs: Observation) -> Command:
        m = self.mission
        state = self.state
        if state is State.DRIVE:
            return Command(speed=m.speed, steering=0.0)
        if state is State.TURN:
            return Command(speed=m.cruise_turn_speed, steering=self._direction * m.steering)
        if state is State.DRIVE_AGAIN:
            remaining = m.final_distance - self._distance(obs)
            # Brake along v = sqrt(2 a d) so the rover comes to rest at the end point.
            speed = min(m.speed, max(CREEP_SPEED, math.sqrt(2 * m.deceleration * remaining)))
            return Command(speed=speed, steering=0.0)
        return Command(speed=0.0, steering=0.0)

    @property
    def entered(self) -> float:
        """When the current state was entered (simulated s)."""
        return self._entered

    @property
    def turned(self) -> float:
        """Heading change accumulated in the current turn (rad)."""
        return self._turned
