"""The ``ray`` placement on a real two-node Ray cluster on this machine (one per module)."""

from __future__ import annotations

import json
import os
import select
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim.core.geo import LocalProjection
from multicosim.placement import ParticipantProgram, ScenarioSimulation
from multicosim.ray import (
    ENV_ADDRESS,
    LocalCluster,
    Ray,
    RayFirmwareNode,
    RayNode,
    RaySimulation,
    RaySimulator,
)

ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'multicosim[ray]')")
if not hasattr(ray, "init"):  # this very directory, found as a namespace package
    pytest.skip("ray is not installed (pip install 'multicosim[ray]')", allow_module_level=True)

# One cluster for the module: its tests must share an xdist worker.
pytestmark = pytest.mark.xdist_group("ray")

HERE = Path(__file__).resolve().parent
MISSION = rover.Mission(speed=3.0, wait=0.5, distance=3.0, final_distance=3.0)
HOME = px4.Home()


def _waypoint(north: float, east: float, alt: float) -> px4.Waypoint:
    lat, lon = LocalProjection(HOME.lat, HOME.lon).reproject(north, east)
    return px4.Waypoint(lat, lon, alt)


HOLD = px4.Configuration([_waypoint(10, 5, 5)], end="hold", time_limit=20.0)


@pytest.fixture(scope="module")
def cluster() -> Iterator[list[str]]:
    """A head and a worker node of one CPU each, joined through ``MCS_RAY_ADDRESS`` as the
    registered placement joins it; the ids of its nodes. Stopped whatever the tests did."""
    if ray.is_initialized():  # another module's connection is not this cluster
        ray.shutdown()
    with LocalCluster(nodes=2, num_cpus=1) as local, pytest.MonkeyPatch.context() as env:
        env.setenv(ENV_ADDRESS, local.address)
        try:
            Ray().prepare()
            deadline = time.monotonic() + 60
            while len(nodes := [n["NodeID"] for n in ray.nodes() if n["Alive"]]) < 2:
                assert time.monotonic() < deadline, f"the cluster has {len(nodes)} node(s)"
                time.sleep(0.1)
            yield nodes
        finally:
            ray.shutdown()


def _ray_nodes(simulation: ScenarioSimulation | RaySimulation) -> list[RayNode]:
    inner = simulation.simulation if isinstance(simulation, ScenarioSimulation) else simulation
    assert isinstance(inner, RaySimulation)
    return inner.ray_nodes()


def _gone(pid: int) -> bool:
    """Whether process ``pid`` has exited (a zombie counts as exited)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state == "Z"


def _wait_gone(pids: list[int], timeout: float = 60.0) -> list[int]:
    """The processes of ``pids`` still running after up to ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while (left := [p for p in pids if not _gone(p)]) and time.monotonic() < deadline:
        time.sleep(0.1)
    return left


def _cluster_idle(timeout: float = 30.0) -> bool:
    """Whether every CPU of the cluster is free again (within ``timeout`` s: Ray reports
    freed resources a little after the actors holding them have gone)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if ray.available_resources().get("CPU", 0) == ray.cluster_resources().get("CPU"):
            return True
        time.sleep(0.1)
    return False


def test_the_rover_flies_the_same_on_ray_as_in_processes(cluster: list[str]) -> None:
    with rover.Rover(fidelity="medium", placement="process", seed=21).start() as simulation:
        local = simulation.controller.send(MISSION)
    with rover.Rover(fidelity="medium", placement="ray", seed=21).start() as simulation:
        world, controller = simulation.world, simulation.controller
        assert isinstance(world, RayNode)
        assert isinstance(controller, RayFirmwareNode)
        on_ray = controller.send(MISSION)
        nodes = _ray_nodes(simulation)
        assert [n.name for n in nodes] == ["world", "controller"]
        # One CPU a node, one an actor: the world and the controller share no node.
        assert {world.node_id, controller.node_id} == set(cluster)
    assert local.completed, local.reason
    assert on_ray == local


def test_px4_flies_the_same_on_ray_as_in_processes(cluster: list[str]) -> None:
    results = []
    for placement in ("process", "ray"):
        simulator = px4.PX4(fidelity="medium", placement=placement, seed=22)
        with simulator.start() as simulation:
            results.append(simulation.firmware.send(HOLD))
            if placement == "ray":
                assert isinstance(simulation.world, RayNode)
                placed = {n.name: n.node_id for n in _ray_nodes(simulation)}
    assert results[0].completed, results[0].reason
    assert results[0].armed
    assert results[1] == results[0]
    assert sorted(placed) == ["px4", "world"]
    assert set(placed.values()) == set(cluster)


def test_stop_leaves_no_actor_process_or_file(cluster: list[str]) -> None:
    simulation = rover.Rover(fidelity="medium", placement="ray", seed=23).start()
    try:
        nodes = _ray_nodes(simulation)
        pids = [p for n in nodes for p in (n.pid, n.handle.worker_pid)]
        actors = [n.actor for n in nodes]
        assert all(not _gone(p) for p in pids)
        simulation.controller.send(MISSION)
        logs = simulation.logs()
        assert sorted(logs) == ["controller", "world"]
        assert logs["controller"].read_text()  # the program's output, brought here
        run_dir = simulation.run_dir
    finally:
        simulation.stop()
    assert not run_dir.exists()
    for actor in actors:
        with pytest.raises(ray.exceptions.RayActorError):
            ray.get(actor.poll.remote(), timeout=10)
    assert _wait_gone(pids) == []
    assert _cluster_idle()


def test_a_crashed_participant_is_named_with_its_output(cluster: list[str]) -> None:
    simulator = RaySimulator(seed=24)
    simulator.add(Ray().participant(ParticipantProgram("ray_programs:crasher", None, "crasher")))
    simulation = simulator.start()
    try:
        (node,) = _ray_nodes(simulation)
        with pytest.raises(mcs.NodeCrashedError) as info:
            simulation.advance(1.0)
    finally:
        simulation.stop()
    error = info.value
    assert error.name == "crasher"
    assert error.exit_code == 1
    assert "crashed (it raised RuntimeError: the crasher gave up at t=0.05 s)" in error.reason
    assert "the crasher is up" in error.log_tail
    assert "RuntimeError: the crasher gave up" in error.log_tail
    assert _wait_gone([node.pid, node.handle.worker_pid]) == []


def test_a_participant_that_cannot_start_is_named_with_its_output(cluster: list[str]) -> None:
    simulator = RaySimulator(seed=25)
    simulator.add(Ray().participant(ParticipantProgram("ray_programs:broken", None, "broken")))
    with pytest.raises(mcs.NodeStartError) as info:
        simulator.start()
    assert info.value.name == "broken"
    assert info.value.exit_code == 1
    assert "before it was ready" in info.value.reason
    assert "about to fail" in info.value.log_tail
    assert "ValueError: this participant cannot be built" in info.value.log_tail
    assert _cluster_idle()


def test_a_lost_actor_is_reported_and_takes_its_program_along(cluster: list[str]) -> None:
    simulator = RaySimulator(seed=26)
    simulator.add(Ray().participant(ParticipantProgram("ray_programs:idle", None, "idle")))
    simulation = simulator.start()
    try:
        (node,) = _ray_nodes(simulation)
        simulation.advance(0.1)
        os.kill(node.handle.worker_pid, signal.SIGKILL)
        with pytest.raises(mcs.NodeCrashedError) as info:
            simulation.advance(60.0)
    finally:
        simulation.stop()
    assert info.value.name == "idle"
    assert "became unreachable (its Ray actor is gone" in info.value.reason
    assert _wait_gone([node.pid]) == []


def test_a_frozen_program_is_a_step_timeout_that_says_so(cluster: list[str]) -> None:
    simulator = RaySimulator(seed=29, step_timeout=1.0)
    simulator.add(Ray().participant(ParticipantProgram("ray_programs:idle", None, "frozen")))
    simulation = simulator.start()
    try:
        (node,) = _ray_nodes(simulation)
        simulation.advance(0.1)
        os.kill(node.pid, signal.SIGSTOP)  # the cluster is on this machine
        with pytest.raises(mcs.NodeTimeoutError) as info:
            simulation.advance(1.0)
    finally:
        simulation.stop()  # continues it, so that it can act on SIGTERM
    assert info.value.name == "frozen"
    assert "it is frozen (its process is stopped, as by SIGSTOP)" in info.value.reason
    assert _wait_gone([node.pid, node.handle.worker_pid]) == []


def test_no_room_on_the_cluster_is_a_start_error_in_time(cluster: list[str]) -> None:
    placement = Ray(num_cpus=64, place_timeout=2.0)
    simulator = RaySimulator(seed=27)
    simulator.add(placement.participant(ParticipantProgram("ray_programs:idle", None, "big")))
    with pytest.raises(mcs.NodeStartError, match="was not running on the Ray cluster within 2 s"):
        simulator.start()
    assert _cluster_idle()


def test_options_place_a_component_on_a_chosen_node(cluster: list[str]) -> None:
    strategy = ray.util.scheduling_strategies.NodeAffinitySchedulingStrategy
    target = cluster[1]
    placement = Ray(
        strategy="DEFAULT",
        options={"world": {"scheduling_strategy": strategy(target, soft=False)}},
    )
    with rover.Rover(fidelity="medium", placement=placement, seed=28).start() as simulation:
        world = simulation.world
        assert isinstance(world, RayNode)
        assert world.node_id == target


def _driver(cluster_address: str) -> tuple[subprocess.Popen[str], dict[str, Any]]:
    """``ray_programs.py`` as a driver of its own; what it printed of its simulation."""
    process = subprocess.Popen(
        [sys.executable, str(HERE / "ray_programs.py")],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, ENV_ADDRESS: cluster_address},
    )
    assert process.stdout is not None
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if select.select([process.stdout], [], [], 1.0)[0]:
            line = process.stdout.readline()
            if line.startswith("{"):
                return process, json.loads(line)
            if not line:
                break
    process.kill()
    pytest.fail(f"the driver did not start its simulation: {process.communicate()[0][-3000:]}")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "kill"])
def test_an_interrupted_or_killed_driver_leaves_nothing_running(
    cluster: list[str], signum: int
) -> None:
    address = os.environ[ENV_ADDRESS]
    process, started = _driver(address)
    pids = [*started["programs"], *started["actors"]]
    assert len(pids) == 4
    process.send_signal(signum)
    try:
        output, _ = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
        raise
    # Ctrl-C stops the simulation on its way out; a killed driver's actors are ended by Ray
    # (their owner is gone), and their programs with them.
    assert _wait_gone(pids) == []
    run_dir = Path(started["run_dir"])
    if signum == signal.SIGKILL:
        assert process.returncode == -signal.SIGKILL, output
    else:  # it ends on the KeyboardInterrupt, once its simulation has stopped
        assert process.returncode != 0
        assert "KeyboardInterrupt" in output
        assert not run_dir.exists()
    shutil.rmtree(run_dir, ignore_errors=True)  # what a killed driver could not remove
    assert _cluster_idle()
