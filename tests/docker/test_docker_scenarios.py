"""The rover and PX4 scenarios on containers: the paper's listing 2, placements that agree."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import pytest

import multicosim as mcs
import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim import trace
from multicosim.core.geo import LocalProjection
from multicosim.docker import (
    ContainerComponent,
    ContainerFirmwareComponent,
    ContainerFirmwareNode,
    ContainerNode,
    ContainerSimulation,
    ContainerSimulator,
    ImageMissingError,
)

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
SHORT_MISSION = rover.Mission(speed=3.0, wait=0.5, distance=3.0, final_distance=3.0)


def _waypoint(north: float, east: float, alt: float) -> px4.Waypoint:
    lat, lon = PROJ.reproject(north, east)
    return px4.Waypoint(lat, lon, alt)


HOLD = px4.Configuration([_waypoint(20, 10, 8)], end="hold", time_limit=40.0)


def test_rover_world_and_typed_firmware_in_containers(image: str) -> None:
    simulator = ContainerSimulator(seed=1)
    simulator.add(ContainerComponent(image, rover.world_command()))
    node_id = simulator.add(
        ContainerFirmwareComponent(
            image=image,
            command="multicosim serve multicosim.rover:controller --host 0.0.0.0 --port {port}",
            port=5556,
            msgtype=rover.Mission,
            replytype=rover.Trajectory,
        )
    )
    with simulator.start() as simulation:
        trajectory = simulation.get(node_id).send(rover.Mission(speed=5))
    assert trajectory.completed, trajectory.reason
    assert trajectory.states() == ["wait", "drive", "turn", "drive_again", "done"]
    x, y, _ = rover.planned_endpoint(rover.Mission(speed=5))
    assert math.hypot(trajectory.final.x - x, trajectory.final.y - y) < 2.0
    assert max(s.speed for s in trajectory) > 4.5


def test_rover_runs_world_and_controller_as_containers(engine: Any, image: str, ours: Any) -> None:
    with rover.Rover(fidelity="high", placement="docker", seed=2).start() as simulation:
        world, controller = simulation.world, simulation.controller
        assert isinstance(world, ContainerNode)
        assert isinstance(controller, ContainerFirmwareNode)
        inner = simulation.simulation
        assert isinstance(inner, ContainerSimulation)
        assert [c.name for c in inner.containers()] == ["world", "controller"]
        for node in (world, controller.container):
            info = engine.api.inspect_container(node.id)
            assert info["Config"]["Image"] == image
            assert inner.network in info["NetworkSettings"]["Networks"]
        # High fidelity: the finer world settings reached the container.
        args = engine.api.inspect_container(world.id)["Config"]["Cmd"]
        assert args == rover.world_command(rover.Rover(fidelity="high").config, "high")
        trajectory = controller.send(SHORT_MISSION)
        assert trajectory.completed, trajectory.reason
        run_id = inner.run_id
    assert ours(run=run_id) == ([], [])


def test_px4_runs_world_and_autopilot_as_containers(engine: Any, image: str, ours: Any) -> None:
    simulator = px4.PX4(fidelity="high", placement="docker", seed=3)
    assert simulator.world == px4.HIGH_FIDELITY_WORLD
    assert simulator.wire == "mavlink"
    with simulator.start() as simulation:
        inner = simulation.simulation
        assert isinstance(inner, ContainerSimulation)
        assert [c.name for c in inner.containers()] == ["world", "px4"]
        assert isinstance(simulation.world, ContainerNode)
        assert simulation.firmware.autopilot is None  # not in this process
        info = engine.api.inspect_container(simulation.world.id)
        assert info["Config"]["Image"] == image
        result = simulation.firmware.send(HOLD)
        assert result.completed, result.reason
        assert result.armed
        run_id = inner.run_id
    assert ours(run=run_id) == ([], [])


PLACEMENTS = ("in-process", "process", "docker")


def _same_bits(runs: Mapping[str, tuple[object, trace.Fingerprint]]) -> None:
    """Every placement's result and every sample equal to the first placement's."""
    (first, (result, reference)), *others = runs.items()
    assert reference.samples > 100
    for placement, (other, fingerprint) in others:
        assert fingerprint == reference, (
            f"{placement} differs from {first}: {reference.first_difference(fingerprint)}"
        )
        assert other == result


@pytest.mark.parametrize("fidelity", ["low", "medium", "high"])
def test_rover_same_seed_same_bits_in_every_placement(
    engine: Any, image: str, fidelity: rover.Fidelity
) -> None:
    runs = {}
    for placement in PLACEMENTS:
        with (
            rover.Rover(fidelity=fidelity, placement=placement, seed=11).start() as simulation,
            trace.Recorder().attach(simulation) as recorder,
        ):
            result = simulation.controller.send(SHORT_MISSION)
        runs[placement] = (result, trace.fingerprint([recorder]))
    assert result.completed, result.reason
    _same_bits(runs)


# Three legs with turns: the guidance's line-following and the turns' braking are flown.
TURNS = px4.Configuration(
    [_waypoint(20, 0, 8), _waypoint(20, 15, 10), _waypoint(0, 15, 8)], end="hold", time_limit=60.0
)


@pytest.mark.parametrize("fidelity", ["low", "medium", "high"])
def test_px4_same_seed_same_bits_in_every_placement(
    engine: Any, image: str, fidelity: px4.Fidelity
) -> None:
    runs = {}
    for placement in PLACEMENTS:
        simulator = px4.PX4(fidelity=fidelity, placement=placement, seed=12)
        with simulator.start() as simulation, trace.Recorder().attach(simulation) as recorder:
            result = simulation.firmware.send(TURNS)
        runs[placement] = (result, trace.fingerprint([recorder]))
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0, 1, 2]
    _same_bits(runs)


def test_px4_components_in_containers_check_their_image_first(engine: Any, image: str) -> None:
    sim = ContainerSimulator()
    sim.add(px4.WorldComponent(px4.WorldConfig(), "medium", placement="docker"))
    sim.add(ContainerComponent("multicosim/missing:0", ["true"], name="missing"))
    with pytest.raises(ImageMissingError, match="multicosim/missing:0"):
        sim.start()
    # A container needs the simulation's network: a simulator of another placement refuses it.
    local = mcs.ProcessSimulator()
    with pytest.raises(mcs.ConfigurationError, match="'docker' placement") as info:
        local.add(px4.WorldComponent(px4.WorldConfig(), "medium", placement="docker"))
    assert info.value.field == "component"


@pytest.mark.parametrize("make", [rover.Rover, px4.PX4])
def test_a_local_placement_refuses_container_components(make: Any) -> None:
    simulator = make(fidelity="medium", placement="process")
    with pytest.raises(mcs.ConfigurationError, match="'docker' placement") as info:
        simulator.add(ContainerComponent("multicosim/runtime:0", "true", name="extra"))
    assert info.value.field == "component"


@pytest.mark.parametrize("make", [rover.Rover, px4.PX4])
def test_docker_scenarios_take_in_process_components(engine: Any, image: str, make: Any) -> None:
    seen: list[float] = []

    class Probe:
        period = 0.1

        def setup(self, ctx: mcs.StepContext) -> None:
            pass

        def step(self, ctx: mcs.StepContext) -> None:
            seen.append(ctx.time)

    simulator = make(fidelity="low", placement="docker")
    simulator.add(mcs.InProcessComponent(Probe, name="probe"))
    with simulator.start() as simulation:
        simulation.advance(1.0)
    assert seen == pytest.approx([0.1 * i for i in range(10)])  # steps in [0, 1)


FIXTURE_SUITE = """
import multicosim.rover as rover
from multicosim import trace
import multicosim.px4 as px4
from multicosim.docker import ContainerNode


def test_rover(rover_simulation):
    assert isinstance(rover_simulation.world, ContainerNode)
    mission = rover.Mission(speed=2.0, wait=0.0, distance=1.0, final_distance=1.0)
    assert rover_simulation.controller.send(mission).completed


def test_px4(px4_simulation):
    assert isinstance(px4_simulation.world, ContainerNode)
    px4_simulation.advance(1.0)
"""


def test_fixtures_run_the_scenarios_on_containers(pytester: pytest.Pytester, image: str) -> None:
    pytester.makepyfile(test_suite=FIXTURE_SUITE)
    result = pytester.runpytest(
        "--mcs-placement=docker", "--mcs-fidelity=low,high", "-p", "no:cacheprovider"
    )
    result.assert_outcomes(passed=4)


def test_fixtures_skip_without_an_engine_unless_required(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch, tmp_path: Any
) -> None:
    monkeypatch.setenv("DOCKER_HOST", f"unix://{tmp_path}/no-engine.sock")
    monkeypatch.delenv("MCS_REQUIRE_DOCKER", raising=False)
    pytester.makepyfile(test_suite=FIXTURE_SUITE)
    args = ("--mcs-placement=docker", "-rs", "-p", "no:cacheprovider")
    result = pytester.runpytest(*args)
    result.assert_outcomes(skipped=2)
    # One short line: where no engine answers; how to start one is in the docs.
    result.stdout.re_match_lines(
        [rf"SKIPPED \[\d+\] \S+: no Docker engine at unix://{tmp_path}/no-engine.sock$"]
    )

    monkeypatch.setenv("MCS_REQUIRE_DOCKER", "1")
    result = pytester.runpytest(*args)
    result.assert_outcomes(errors=2)
    result.stdout.fnmatch_lines(["*MCS_REQUIRE_DOCKER=1 but no Docker engine*not running*"])
