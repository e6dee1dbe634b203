"""Containers run hardened: non-root, no capabilities, limited, labelled, on their network."""

from __future__ import annotations

from typing import Any

import pytest
from docker_helpers import wait_for

import multicosim as mcs
from multicosim.docker import ContainerComponent, ContainerLimits, ContainerSimulator

SLEEP = "sleep 600"


def test_started_containers_are_hardened(engine: Any, image: str) -> None:
    simulator = ContainerSimulator()
    default_id = simulator.add(ContainerComponent(image, SLEEP, name="plain", ready="started"))
    custom_id = simulator.add(
        ContainerComponent(
            image,
            SLEEP,
            name="custom",
            ready="started",
            limits=ContainerLimits(memory="256m", pids=64),
        )
    )
    with simulator.start() as simulation:
        for node_id, memory, pids in ((default_id, 2 << 30, 512), (custom_id, 256 << 20, 64)):
            node = simulation.get(node_id)
            info = engine.api.inspect_container(node.id)
            host = info["HostConfig"]
            assert info["Config"]["User"] == "10001:10001"
            assert host["CapDrop"] == ["ALL"]
            assert host["SecurityOpt"] == ["no-new-privileges:true"]
            assert not host["Privileged"]
            assert (host["Memory"], host["MemorySwap"], host["PidsLimit"]) == (memory, memory, pids)
            assert host["Init"] is True
            assert host["NetworkMode"] == simulation.network  # its own network, never "host"
            labels = info["Config"]["Labels"]
            assert labels["multicosim.run"] == simulation.run_id
            assert labels["multicosim.component"] == node.name
            assert {"multicosim.session", "multicosim.owner"} <= set(labels)
            # What the engine enforces, seen from inside.
            code, out = node.container.exec_run(["sh", "-c", "id -u; grep CapEff /proc/1/status"])
            assert code == 0
            uid, caps = out.decode().split("\n", 1)
            assert uid == "10001"
            assert caps.split()[1] == "0000000000000000"
        network = engine.api.inspect_network(simulation.network)
        assert network["Labels"]["multicosim.run"] == simulation.run_id


def test_limits_are_enforced(engine: Any, image: str) -> None:
    simulator = ContainerSimulator()
    forks = simulator.add(
        ContainerComponent(
            image,
            ["sh", "-c", "for i in $(seq 40); do sleep 600 & done; wait"],
            name="forks",
            ready="started",
            limits=ContainerLimits(pids=16),
        )
    )
    hog = simulator.add(
        ContainerComponent(
            image,
            ["python3", "-c", "b = bytearray(512 << 20); print('allocated', flush=True)"],
            name="hog",
            ready="started",
            limits=ContainerLimits(memory="64m"),
        )
    )
    simulation = simulator.start()
    try:
        hog_node = simulation.get(hog)
        assert _wait_exit(hog_node) == 137  # killed by the memory limit
        assert "allocated" not in hog_node.logs()
        forks_node = simulation.get(forks)
        assert wait_for(lambda: "fork" in forks_node.logs().lower()), forks_node.logs()
    finally:
        with pytest.raises(ExceptionGroup) as info:
            simulation.stop()  # the memory hog had exited: reported at stop, as any crash
    assert info.group_contains(
        mcs.NodeCrashedError,
        match=r"'hog' ran out of memory \(killed at its container's memory limit of 64 MiB\)",
    )


def _wait_exit(node: Any, timeout: float = 60.0) -> int | None:
    assert wait_for(lambda: node.poll() is not None, timeout)
    code: int | None = node.poll()
    return code


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"memory": "lots"}, "memory"),
        ({"memory": 1024}, "memory"),
        ({"memory": True}, "memory"),
        ({"pids": 0}, "pids"),
        ({"pids": 10.5}, "pids"),
        ({"user": ""}, "user"),
        ({"user": "a b"}, "user"),
    ],
)
def test_invalid_limits_are_refused(kwargs: dict[str, Any], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        ContainerLimits(**kwargs)
    assert info.value.field == field


def test_limits_must_be_container_limits() -> None:
    with pytest.raises(mcs.ConfigurationError, match="limits"):
        ContainerComponent("img", SLEEP, limits={"memory": "1g"})  # type: ignore[arg-type]
