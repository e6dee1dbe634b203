"""The sensor injector as a container: the same attack gives the same run in every placement."""

from __future__ import annotations

import multicosim.attacks as attacks
import multicosim.rover as rover

MISSION = rover.Mission(speed=3.0, wait=1.0, distance=5.0, final_distance=5.0)


def _run(placement: str) -> rover.Trajectory:
    simulator = rover.Rover(fidelity="low", placement=placement)
    component = attacks.inject(
        simulator,
        "gps",
        [attacks.Gaussian(std=0.2), attacks.Jump(offset=attacks.Local(east=2.0), start=2)],
    )
    assert component.config.source == "rover/position/raw"
    with simulator.start() as simulation:
        return simulation.controller.send(MISSION)


def test_injector_container_corrupts_like_the_in_process_one(image: str) -> None:
    in_docker = _run("docker")
    assert in_docker.completed, in_docker.reason
    assert in_docker == _run("in-process")
