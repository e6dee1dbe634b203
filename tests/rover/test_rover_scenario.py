"""The rover scenario end to end: simulators, fidelity levels, processes, attacks."""

from __future__ import annotations

import dataclasses
import itertools
import math

import msgspec
import pytest
from hypothesis import HealthCheck, given, settings

import multicosim as mcs
import multicosim.rover as rover
from multicosim.physics import WorldConfig
from multicosim.rover import (
    ABORT_TOPIC,
    SENSOR_TOPICS,
    WHEELBASE,
    Abort,
    MagneticField,
    Mission,
    Trajectory,
    planned_endpoint,
)
from multicosim.rover.strategies import missions, sensor_noise, world_configs

SHORT = Mission(speed=3.0, wait=0.5, distance=4.0, final_distance=4.0)


def _distance_to_plan(trajectory: Trajectory, mission: Mission) -> float:
    x, y, _ = planned_endpoint(mission)
    return math.hypot(trajectory.final.x - x, trajectory.final.y - y)


# -- configuration --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"fidelity": "ultra"}, "fidelity"),
        ({"placement": "kubernetes"}, "placement"),
        ({"seed": -1}, "seed"),
        ({"world": {"timestep": 0.001}}, "world"),
        ({"noise": 0.1}, "noise"),
        ({"world": WorldConfig(sensor_topics={"sonar": "x"})}, "sensor_topics"),
    ],
)
def test_invalid_rover_configuration(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        rover.Rover(**kwargs)  # type: ignore[arg-type]
    assert info.value.field == field
    if field == "placement":
        assert "'process'" in info.value.allowed  # the registered names are listed


def test_fidelity_defaults() -> None:
    assert rover.Rover("low").config.noise.ideal
    medium, high = rover.Rover("medium").config, rover.Rover("high").config
    assert not medium.noise.ideal
    assert high.world.timestep < medium.world.timestep
    custom = WorldConfig(timestep=0.001, solver="CG")
    assert rover.Rover("high", world=custom).config.world == custom


# -- low fidelity ---------------------------------------------------------------------------


def test_low_fidelity_mission() -> None:
    with rover.Rover(fidelity="low").start() as simulation:
        trajectory = simulation.controller.send(SHORT)
        assert simulation.time >= trajectory.final.time
    assert trajectory.completed
    assert trajectory.states() == ["wait", "drive", "turn", "drive_again", "done"]
    assert _distance_to_plan(trajectory, SHORT) < 0.5
    # Sampled at the mission's rate (20 Hz by default).
    steps = {round(b - a, 9) for a, b in itertools.pairwise(trajectory.times)}
    assert steps == {0.05}


def test_missions_continue_from_where_the_rover_stopped() -> None:
    with rover.Rover(fidelity="low").start() as simulation:
        first = simulation.controller.send(SHORT)
        second = simulation.controller.send(SHORT)
    assert second.start_time >= first.final.time  # the clock is frozen between missions
    assert second.samples[0].x == pytest.approx(first.final.x, abs=1e-6)
    assert second.samples[0].heading == pytest.approx(first.final.heading, abs=1e-6)
    assert second.completed


def test_abort_published_on_the_topic_stops_the_rover() -> None:
    @dataclasses.dataclass
    class Operator:
        """Publishes an abort once, at ``when`` simulated seconds."""

        when: float
        period: float = 0.05
        sent: bool = False

        def setup(self, ctx: mcs.StepContext) -> None:
            pass

        def step(self, ctx: mcs.StepContext) -> None:
            if not self.sent and ctx.time >= self.when:
                ctx.publish(ABORT_TOPIC, Abort(reason="operator"))
                self.sent = True

    simulator = rover.Rover(fidelity="low")
    simulator.add(mcs.InProcessComponent(lambda: Operator(when=2.0), name="operator"))
    with simulator.start() as simulation:
        trajectory = simulation.controller.send(SHORT)
        # A later mission is not aborted by the stale message.
        again = simulation.controller.send(SHORT)
    assert trajectory.final_state == "aborted"
    assert trajectory.reason == "aborted: operator"
    assert not trajectory.completed
    assert abs(trajectory.final.speed) < 0.05
    assert again.completed


def test_compass_attack_changes_the_turn() -> None:
    """An injector between the magnetometer and the controller bends the rover's path."""
    offset = math.radians(20.0)

    class CompassAttack:
        """Rotates the magnetic field the controller reads by ``offset`` after 3 s."""

        period = 0.025

        def setup(self, ctx: mcs.StepContext) -> None:
            self.raw = ctx.subscribe("attack/magnetometer", MagneticField)

        def step(self, ctx: mcs.StepContext) -> None:
            for m in self.raw.messages:
                a = offset if ctx.time >= 3.0 else 0.0
                x = m.x * math.cos(a) - m.y * math.sin(a)
                y = m.x * math.sin(a) + m.y * math.cos(a)
                ctx.publish(
                    SENSOR_TOPICS["magnetometer"], MagneticField(time=m.time, x=x, y=y, z=m.z)
                )

    world = dataclasses.replace(
        rover.default_world("low"), sensor_topics={"magnetometer": "attack/magnetometer"}
    )
    honest = rover.Rover(fidelity="low", world=world)
    honest.add(mcs.InProcessComponent(lambda: _Relay(), name="relay"))
    attacked = rover.Rover(fidelity="low", world=world)
    attacked.add(mcs.InProcessComponent(CompassAttack, name="attack"))
    with honest.start() as simulation:
        clean = simulation.controller.send(SHORT)
    with attacked.start() as simulation:
        fooled = simulation.controller.send(SHORT)
    assert clean.completed
    assert fooled.completed
    assert _distance_to_plan(clean, SHORT) < 0.5
    # The controller believes it turned 70 degrees; it really turned about 20 fewer.
    assert _distance_to_plan(fooled, SHORT) > 1.0


class _Relay:
    """Republishes the remapped magnetometer unchanged (a zero-effect injector)."""

    period = 0.025

    def setup(self, ctx: mcs.StepContext) -> None:
        self.raw = ctx.subscribe("attack/magnetometer", MagneticField)

    def step(self, ctx: mcs.StepContext) -> None:
        for m in self.raw.messages:
            ctx.publish(SENSOR_TOPICS["magnetometer"], m)


def test_controller_without_a_world_fails_clearly() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.InProcessFirmwareComponent(rover.controller))
    with (
        simulator.start() as simulation,
        pytest.raises(mcs.MulticosimError, match="no sensor data"),
    ):
        simulation.get(node_id).send(SHORT)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(missions(speed=(0.5, 4.0)))
def test_any_mission_ends_near_its_plan_at_low_fidelity(mission: Mission) -> None:
    with rover.Rover(fidelity="low").start() as simulation:
        trajectory = simulation.controller.send(mission)
    assert trajectory.completed, trajectory.reason
    # Errors come from deciding at the control rate: the turn can overshoot by one period
    # of yaw, which the final leg turns into a lateral offset.
    dt = 1 / mission.rate
    yaw_step = mission.cruise_turn_speed * math.tan(mission.steering) / WHEELBASE * dt
    tolerance = 0.3 + mission.speed * dt + (mission.final_distance + 3.0) * (yaw_step + 0.02)
    # A final leg shorter than the braking distance cannot end where the plan says.
    braking = mission.speed**2 / (2 * rover.ACCELERATION)
    tolerance += max(0.0, braking - mission.final_distance)
    assert _distance_to_plan(trajectory, mission) < tolerance


@settings(max_examples=20, deadline=None)
@given(world_configs(remap=True), sensor_noise())
def test_strategies_draw_valid_configurations(world: WorldConfig, noise: rover.SensorNoise) -> None:
    config = rover.RoverWorldConfig(world=world, noise=noise)
    assert config.world.timestep <= config.world.period
    assert set(world.sensor_topics) <= set(SENSOR_TOPICS)


# -- processes (medium and high fidelity) ---------------------------------------------------


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(world_configs(timestep=(0.001, 0.005)))
def test_drawn_world_configurations_drive_the_mission(world: WorldConfig) -> None:
    mission = Mission(speed=3.0, wait=0.0, distance=3.0, final_distance=2.0)
    with rover.Rover(fidelity="medium", world=world).start() as simulation:
        trajectory = simulation.controller.send(mission)
    assert trajectory.completed
    assert max(abs(s.roll) for s in trajectory) < 0.2  # upright all along
    assert _distance_to_plan(trajectory, mission) < 1.5


def test_typed_interfaces() -> None:
    """Rover is a Simulator; the controller node is typed (checked by mypy on this file)."""
    from typing import assert_type

    from multicosim.local import LocalEnvironment

    simulator: mcs.Simulator[LocalEnvironment] = rover.Rover(fidelity="low")
    simulation = rover.Rover(fidelity="low").start()
    try:
        assert_type(simulation.controller, mcs.CommunicationNode[Mission, Trajectory])
        assert isinstance(simulation.controller, mcs.CommunicationNode)
    finally:
        simulation.stop()
    assert simulator is not None


def test_listing_2_shape(no_leaks: None) -> None:
    """The paper's listing 2: world and firmware components added to a simulator by hand."""
    simulator = mcs.ProcessSimulator(seed=0)
    simulator.add(
        mcs.ProcessComponent("python -m multicosim participant multicosim.rover.body:rover_world")
    )
    node_id = simulator.add(
        mcs.ProcessFirmwareComponent(
            "python -m multicosim serve multicosim.rover:controller --port {port}",
            msgtype=Mission,
            replytype=Trajectory,
        )
    )
    simulation = simulator.start()
    try:
        node = simulation.get(node_id)
        trajectory = node.send(Mission(speed=5, wait=0.5))
    finally:
        simulation.stop()
    assert isinstance(trajectory, Trajectory)
    assert trajectory.completed


def test_low_and_medium_agree_on_the_outcome(no_leaks: None) -> None:
    outcomes = {}
    for fidelity in ("low", "medium"):
        with rover.Rover(fidelity=fidelity).start() as simulation:
            outcomes[fidelity] = simulation.controller.send(SHORT)
    low, medium = outcomes["low"], outcomes["medium"]
    assert low.final_state == medium.final_state == "done"
    assert low.states() == medium.states()
    assert math.hypot(low.final.x - medium.final.x, low.final.y - medium.final.y) < 1.0
    assert math.remainder(low.final.heading - medium.final.heading, math.tau) == pytest.approx(
        0.0, abs=math.radians(10)
    )
    assert abs((low.final.time - low.start_time) - (medium.final.time - medium.start_time)) < 2.0


def test_high_fidelity_runs_the_finer_world(no_leaks: None) -> None:
    mission = msgspec.structs.replace(SHORT, distance=2.0, final_distance=2.0)
    with rover.Rover(fidelity="high").start() as simulation:
        trajectory = simulation.controller.send(mission)
    assert trajectory.completed
    assert _distance_to_plan(trajectory, mission) < 1.0
