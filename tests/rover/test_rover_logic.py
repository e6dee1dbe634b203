"""Rover messages, vehicle geometry, the automaton and the kinematic world (no processes)."""

from __future__ import annotations

import math
from typing import Any

import msgspec
import pytest

import multicosim as mcs
from multicosim.core.geo import quaternion_from_euler
from multicosim.rover import (
    COMMAND_TOPIC,
    MAX_STEERING,
    SENSOR_TOPICS,
    TRACK,
    WHEELBASE,
    Automaton,
    Command,
    KinematicWorld,
    MagneticField,
    Mission,
    Observation,
    Position,
    RoverWorldConfig,
    SensedSample,
    SensorNoise,
    State,
    Trajectory,
    ackermann,
    heading_from_field,
    planned_endpoint,
)
from multicosim.rover._vehicle import field_in_body, roll_from_quaternion, yaw_from_quaternion

# -- messages -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("speed", 0.0),
        ("speed", -1.0),
        ("speed", 11.0),
        ("speed", math.inf),
        ("wait", -1.0),
        ("distance", -0.1),
        ("final_distance", math.nan),
        ("turn_angle", 0.0),
        ("turn_angle", 4.0),
        ("steering", 0.0),
        ("steering", 0.6),
        ("turn_speed", 0.0),
        ("deceleration", 5.0),
        ("turn_timeout", 0.0),
        ("timeout", -5.0),
        ("abort_at", -1.0),
        ("rate", 5.0),
        ("rate", 5000.0),
    ],
)
def test_invalid_mission_names_the_field(field: str, value: Any) -> None:
    kwargs: dict[str, Any] = {"speed": 2.0, field: value}
    with pytest.raises(mcs.ConfigurationError) as info:
        Mission(**kwargs)
    assert info.value.field == field


def test_mission_defaults_follow_the_reference_rover() -> None:
    mission = Mission(speed=5)
    assert (mission.wait, mission.distance, mission.final_distance) == (5.0, 7.0, 7.0)
    assert math.degrees(mission.turn_angle) == pytest.approx(70.0)
    assert mission.steering == MAX_STEERING
    assert mission.cruise_turn_speed == 5
    assert Mission(speed=5, turn_speed=2.0).cruise_turn_speed == 2.0


def test_mission_is_validated_when_decoded() -> None:
    data = msgspec.msgpack.encode({"speed": 50.0})
    with pytest.raises(msgspec.ValidationError, match="speed"):
        msgspec.msgpack.decode(data, type=Mission)


def test_trajectory_helpers() -> None:
    samples = [
        SensedSample(time=t, x=t, y=0.0, z=0.25, heading=0.0, roll=0.0, speed=1.0, state=s)
        for t, s in [(0.0, "wait"), (0.1, "wait"), (0.2, "drive"), (0.3, "done")]
    ]
    trajectory = Trajectory(samples=samples, final_state="done", completed=True)
    assert len(trajectory) == 4
    assert trajectory.final.time == 0.3
    assert trajectory.times == [0.0, 0.1, 0.2, 0.3]
    assert trajectory.states() == ["wait", "drive", "done"]
    assert [s.x for s in trajectory] == [0.0, 0.1, 0.2, 0.3]
    assert msgspec.json.decode(msgspec.json.encode(trajectory), type=Trajectory) == trajectory


# -- vehicle geometry and sensor conventions ------------------------------------------------


def test_ackermann_geometry() -> None:
    assert ackermann(2.0, 0.0) == (0.0, 0.0, 8.0, 8.0)
    left, right, rate_left, rate_right = ackermann(2.0, 0.4)
    assert left > 0.4 > right > 0  # the inner (left) wheel turns more
    assert rate_left < 8.0 < rate_right  # the outer wheel spins faster
    # Both front wheels point at the same centre on the rear axle line.
    radius = WHEELBASE / math.tan(0.4)
    assert WHEELBASE / math.tan(left) == pytest.approx(radius - TRACK / 2)
    assert WHEELBASE / math.tan(right) == pytest.approx(radius + TRACK / 2)
    mirrored = ackermann(2.0, -0.4)
    assert mirrored == pytest.approx((-right, -left, rate_right, rate_left))


@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.0, math.pi - 0.01])
def test_orientation_conventions(yaw: float) -> None:
    q = quaternion_from_euler(0.1, 0.0, yaw)
    assert yaw_from_quaternion(q) == pytest.approx(yaw)
    assert roll_from_quaternion(q) == pytest.approx(0.1)
    bx, by, _ = field_in_body((0.0, 2e-5, -4e-5), 0.0, 0.0, yaw)
    assert heading_from_field(bx, by) == pytest.approx(yaw)


# -- the automaton --------------------------------------------------------------------------


def _state(automaton: Automaton) -> State:
    # A call, so a type checker does not narrow the state across updates.
    return automaton.state


def _drive(automaton: Automaton, path: list[tuple[float, float, float, float]]) -> list[str]:
    states = []
    for t, x, y, heading in path:
        automaton.update(Observation(time=t, x=x, y=y, heading=heading, speed=1.0))
        states.append(automaton.state.value)
    return states


def test_automaton_follows_the_plan() -> None:
    mission = Mission(speed=2.0, wait=1.0, distance=2.0, turn_angle=math.radians(90))
    automaton = Automaton(mission, start_time=10.0)
    assert automaton.update(Observation(10.0, 0.0, 0.0, 0.0, 0.0)) == Command(
        speed=0.0, steering=0.0
    )
    assert _state(automaton) is State.WAIT
    command = automaton.update(Observation(11.0, 0.0, 0.0, 0.0, 0.0))
    assert _state(automaton) is State.DRIVE
    assert command == Command(speed=2.0, steering=0.0)
    command = automaton.update(Observation(12.0, 2.0, 0.0, 0.0, 2.0))
    assert _state(automaton) is State.TURN
    assert command == Command(speed=2.0, steering=MAX_STEERING)
    automaton.update(Observation(12.5, 2.5, 0.5, math.radians(80), 2.0))
    assert _state(automaton) is State.TURN
    automaton.update(Observation(13.0, 2.5, 1.0, math.radians(91), 2.0))
    assert _state(automaton) is State.DRIVE_AGAIN
    command = automaton.update(Observation(13.5, 2.5, 7.5, math.radians(90), 2.0))
    assert command.speed < 2.0  # braking towards the end point
    automaton.update(Observation(14.0, 2.5, 8.0, math.radians(90), 0.3))
    assert _state(automaton) is State.DONE
    assert automaton.terminal
    assert automaton.completed
    assert automaton.update(Observation(14.1, 2.5, 8.0, 0.0, 0.0)).speed == 0.0


def test_right_turn_and_unwrapping_past_180_degrees() -> None:
    mission = Mission(speed=1.0, wait=0.0, distance=0.0, turn_angle=-math.pi)
    automaton = Automaton(mission, 0.0)
    headings = [0.0, -1.0, -2.0, -3.0, 3.0, 2.9]  # crosses -pi to +pi
    states = _drive(automaton, [(i * 0.1, 0.0, 0.0, h) for i, h in enumerate(headings)])
    assert states[:4] == ["turn"] * 4
    assert states[4] == "drive_again"  # -3.0 then 3.0 is a further -0.28 rad: past -pi
    assert automaton.update(Observation(1.0, 0.0, 0.0, 3.0, 0.0)).steering == 0.0


@pytest.mark.parametrize("state", ["wait", "drive", "turn", "drive_again"])
def test_abort_stops_from_any_state(state: str) -> None:
    mission = Mission(speed=1.0, wait=1.0, distance=1.0, final_distance=5.0)
    automaton = Automaton(mission, 0.0)
    path = [(0.0, 0, 0, 0), (1.0, 0, 0, 0), (2.0, 1, 0, 0), (3.0, 1, 1, 1.3), (3.5, 1, 2, 1.3)]
    for t, x, y, h in path:
        if automaton.state.value == state:
            break
        automaton.update(Observation(t, x, y, h, 1.0))
    assert automaton.state.value == state
    command = automaton.update(Observation(4.0, 1.0, 2.0, 1.3, 1.0), abort="operator")
    assert _state(automaton) is State.ABORTED
    assert command == Command(speed=0.0, steering=0.0)
    assert automaton.reason == "aborted: operator"
    assert not automaton.completed


def test_turn_and_mission_timeouts() -> None:
    automaton = Automaton(Mission(speed=1.0, wait=0.0, distance=0.0, turn_timeout=2.0), 0.0)
    _drive(automaton, [(0.0, 0, 0, 0), (1.0, 0, 0, 0.1), (2.0, 0, 0, 0.2)])
    assert _state(automaton) is State.TIMED_OUT
    assert "turn timeout" in automaton.reason
    automaton = Automaton(Mission(speed=1.0, wait=100.0, timeout=5.0), 0.0)
    _drive(automaton, [(0.0, 0, 0, 0), (5.0, 0, 0, 0)])
    assert _state(automaton) is State.TIMED_OUT
    assert "mission timeout" in automaton.reason


# -- the kinematic world --------------------------------------------------------------------


def _kinematic(command: Command, duration: float, noise: SensorNoise | None = None) -> Any:
    world = KinematicWorld(RoverWorldConfig(noise=noise or SensorNoise()))
    received: dict[str, Any] = {}

    class Probe:
        period = world.period

        def setup(self, ctx: mcs.StepContext) -> None:
            self.position = ctx.subscribe(SENSOR_TOPICS["position"], Position)
            self.field = ctx.subscribe(SENSOR_TOPICS["magnetometer"], MagneticField)

        def step(self, ctx: mcs.StepContext) -> None:
            ctx.publish(COMMAND_TOPIC, command)
            received["position"] = self.position.latest
            received["field"] = self.field.latest

    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(lambda: world, name="world"))
    simulator.add(mcs.InProcessComponent(Probe, name="probe"))
    with simulator.start() as simulation:
        simulation.advance(duration)
    return world, received


def test_kinematic_world_accelerates_at_the_drive_limit() -> None:
    world, received = _kinematic(Command(speed=3.2, steering=0.0), 1.0 + 1e-9)
    # The command published at t=0 acts from t=0: 1 s at 3.2 m/s^2.
    assert world.speed == pytest.approx(3.2, rel=1e-9)
    assert world.x == pytest.approx(0.5 * 3.2, rel=1e-9)
    assert world.y == 0.0
    assert received["position"].x == pytest.approx(world.x, abs=0.1)


def test_kinematic_world_drives_exact_circles() -> None:
    steering = 0.3
    radius = WHEELBASE / math.tan(steering)
    world, received = _kinematic(Command(speed=1.0, steering=steering), 30.0)
    # Rear axle centre stays on the circle around (0, radius) once moving.
    assert math.hypot(world.x, world.y - radius) == pytest.approx(radius, rel=1e-9)
    field = received["field"]
    assert heading_from_field(field.x, field.y) == pytest.approx(world.heading, abs=0.05)


def test_kinematic_world_noise() -> None:
    ideal, _ = _kinematic(Command(speed=0.0, steering=0.0), 0.5)
    _, noisy = _kinematic(Command(speed=0.0, steering=0.0), 0.5, SensorNoise(position=0.5))
    assert ideal.x == 0.0
    assert noisy["position"].x != 0.0


def test_planned_endpoint() -> None:
    square = Mission(speed=1.0, distance=5.0, turn_angle=math.pi / 2, final_distance=5.0)
    radius = WHEELBASE / math.tan(square.steering)
    x, y, heading = planned_endpoint(square)
    assert (x, y, heading) == pytest.approx((5.0 + radius, radius + 5.0, math.pi / 2))
    right = Mission(speed=1.0, distance=5.0, turn_angle=-math.pi / 2, final_distance=5.0)
    assert planned_endpoint(right) == pytest.approx((5.0 + radius, -radius - 5.0, -math.pi / 2))


def test_public_names() -> None:
    import multicosim.physics
    import multicosim.rover

    for module in (multicosim.rover, multicosim.physics):
        missing = [name for name in module.__all__ if not hasattr(module, name)]
        assert not missing, f"{module.__name__} does not define {missing}"
        assert sorted(module.__all__) == sorted(set(module.__all__))
