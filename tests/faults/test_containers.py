"""Faults of containers in a running simulation on the Docker backend (the rover's MuJoCo
world and its controller, each a container): killed, cut off from the simulation's network,
out of memory. Each is reported naming the component and the fault.
"""

from __future__ import annotations

import subprocess
from typing import Any

import pytest
from fault_helpers import Detections, Trigger, at_time, failing, stamped

import multicosim as mcs
import multicosim.rover as rover
from multicosim import testing
from multicosim.docker import ContainerComponent, ContainerLimits, ContainerSimulator
from multicosim.local import participant_command

STEP_TIMEOUT = 2.0  # s: short, so that an unreachable component is reported soon
FAULT_AT = 5.0  # s of simulated time: the rover is driving its first leg
MISSION = rover.Mission(speed=5.0)
CRASH = 0.0  # a container's exit is seen at the next liveness check


def simulator(*extra: Any) -> tuple[ContainerSimulator, mcs.NodeId[Any], mcs.NodeId[Any]]:
    """The rover world and controller as containers, ``extra`` between them."""
    sim = ContainerSimulator(seed=1, step_timeout=STEP_TIMEOUT)
    world = sim.add(rover.world_component("medium", placement="docker"))
    for component in extra:
        sim.add(component)
    return sim, world, sim.add(rover.controller_component("medium", placement="docker"))


def docker(*args: str) -> None:
    """Run the docker command line (the engine's own client, as an operator would)."""
    subprocess.run(["docker", *args], check=True, capture_output=True, timeout=60)


def next_run_is_unaffected() -> None:
    """The same simulation again, without the fault: it completes its mission."""
    sim, _, controller = simulator()
    with sim.start() as simulation:
        trajectory = simulation.get(controller).send(MISSION)
    assert trajectory.completed, trajectory.reason


@pytest.mark.parametrize("fault", ["killed", "disconnected"])
def test_world_container_fails_mid_run(
    mcs_runtime_image: str, detections: Detections, fault: str
) -> None:
    target: list[str] = []  # what the trigger acts on, known once the simulation runs
    if fault == "killed":
        trigger = Trigger(at_time(FAULT_AT), lambda: docker("kill", target[1]))
    else:
        trigger = Trigger(at_time(FAULT_AT), lambda: docker("network", "disconnect", "-f", *target))
    sim, world, controller = simulator(mcs.InProcessComponent(lambda: trigger, name="fault"))
    with sim.start() as simulation:
        target += [simulation.network, simulation.get(world).id]
        error, error_at = failing(lambda: simulation.get(controller).send(MISSION), mcs.NodeError)
    assert trigger.fault_at is not None
    assert error.name == "world"
    if fault == "killed":
        assert isinstance(error, mcs.NodeCrashedError)
        assert error.exit_code == 137
        # Killed between two of its steps: the next finds it gone.
        assert "'world' crashed (killed by SIGKILL) before its step at t=5" in str(error)
        record = ("container killed (docker kill)", CRASH)
    else:
        assert isinstance(error, mcs.NodeTimeoutError)
        assert f"within {STEP_TIMEOUT:g} s: it is unreachable (disconnected from its " in str(error)
        assert target[0] in str(error)
        record = ("container disconnected from its network", STEP_TIMEOUT)
    detections.record(record[0], trigger.fault_at, error_at, record[1], error)
    next_run_is_unaffected()


def test_container_out_of_memory(mcs_runtime_image: str, detections: Detections) -> None:
    command = participant_command("multicosim.testing:Faulty", testing.Fault("hog", FAULT_AT))
    hog = ContainerComponent(
        mcs_runtime_image, command, name="faulty", limits=ContainerLimits(memory="256m")
    )
    sim, _, controller = simulator(hog)
    with sim.start() as simulation:
        error, error_at = failing(
            lambda: simulation.get(controller).send(MISSION), mcs.NodeCrashedError
        )
    assert error.name == "faulty"
    assert (
        "'faulty' ran out of memory (killed at its container's memory limit of 256 MiB) "
        "during its step" in str(error)
    )
    detections.record("container out of memory", stamped(error.log_tail), error_at, CRASH, error)
    next_run_is_unaffected()
