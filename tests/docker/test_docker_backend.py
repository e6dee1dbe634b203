"""The Docker backend against a real engine: lifecycle, firmware, lockstep, attached stacks."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
from multicosim.docker import (
    AttachedComponent,
    ContainerComponent,
    ContainerFirmwareComponent,
    ContainerNode,
    ContainerSimulator,
)
from multicosim.docker import _selftest as st
from multicosim.runtime.context import derive_seed

SERVE = "multicosim serve multicosim.docker._selftest:{} --host 0.0.0.0 --port {{port}}"
WORLD = "multicosim participant multicosim.docker._selftest:World"


def echo(image: str, **kw: Any) -> ContainerFirmwareComponent[st.Echo, st.EchoReply]:
    kw.setdefault("name", "echo")
    return ContainerFirmwareComponent(
        image=image, command=SERVE.format("echo"), msgtype=st.Echo, replytype=st.EchoReply, **kw
    )


def test_container_lifecycle_labels_and_cleanup(engine: Any, image: str, ours: Any) -> None:
    sim = ContainerSimulator(seed=1)
    world_id = sim.add(ContainerComponent(image, WORLD, name="world"))
    simulation = sim.start()
    try:
        node = simulation.get(world_id)
        assert isinstance(node, ContainerNode)
        info = engine.api.inspect_container(node.id)
        assert info["State"]["Running"]
        assert info["HostConfig"]["Init"] is True
        labels = info["Config"]["Labels"]
        assert labels["multicosim.run"] == simulation.run_id
        assert labels["multicosim.session"]
        assert labels["multicosim.owner"].split("/")[2].isdigit()
        assert simulation.network in info["NetworkSettings"]["Networks"]
        assert ours(run=simulation.run_id) == (
            [f"/{simulation.run_id}-world"],
            [simulation.network],
        )
        # Lockstep reaches the participant: time advances only through it.
        simulation.advance(0.05)
        assert simulation.time == pytest.approx(0.05)
        assert node.poll() is None
    finally:
        simulation.stop()
    assert ours(run=simulation.run_id) == ([], [])
    simulation.stop()  # idempotent


def test_firmware_round_trip_through_loopback_port(engine: Any, image: str) -> None:
    sim = ContainerSimulator(seed=7)
    fw = sim.add(echo(image))
    with sim.start() as simulation:
        node = simulation.get(fw)
        reply = node.send(st.Echo("hello"))
        assert reply == st.EchoReply("hello", reply.host, "echo", derive_seed(7, "echo"))
        assert reply.host == node.container.id[:12]  # it really ran in that container
        bindings = engine.api.inspect_container(node.container.id)["HostConfig"]["PortBindings"]
        assert bindings["5556/tcp"] == [{"HostIp": "127.0.0.1", "HostPort": ""}]
        assert node.endpoint == f"tcp://127.0.0.1:{node.host_port}"
        assert [node.send(st.Echo(str(i))).text for i in range(50)] == [str(i) for i in range(50)]


def _lockstep(sim: Any, world: Any, controller: Any) -> st.Trajectory:
    sim.add(world)
    fw = sim.add(controller)
    with sim.start() as simulation:
        trajectory: st.Trajectory = simulation.get(fw).send(st.Mission(speed=2.0, steps=40))
        assert simulation.time == pytest.approx(39 * 0.05)
    return trajectory


def test_lockstep_containers_match_in_process_run(engine: Any, image: str) -> None:
    in_process = _lockstep(
        mcs.ProcessSimulator(seed=3),
        mcs.InProcessComponent(st.World, name="world"),
        mcs.InProcessFirmwareComponent(st.controller),
    )
    containers = _lockstep(
        ContainerSimulator(seed=3),
        ContainerComponent(image, WORLD, name="world"),
        ContainerFirmwareComponent(
            image=image,
            command=SERVE.format("controller"),
            msgtype=st.Mission,
            replytype=st.Trajectory,
        ),
    )
    assert containers == in_process
    assert containers.times[:3] == [0.0, 0.05, 0.1]
    assert containers.xs[-1] == pytest.approx(2.0 * 0.05 * 39, abs=0.11)


def test_in_process_world_with_container_controller(engine: Any, image: str) -> None:
    mixed = _lockstep(
        ContainerSimulator(seed=3),
        mcs.InProcessComponent(st.World, name="world"),
        ContainerFirmwareComponent(
            image=image,
            command=SERVE.format("controller"),
            msgtype=st.Mission,
            replytype=st.Trajectory,
        ),
    )
    assert mixed.xs[:4] == pytest.approx([0.0, 0.1, 0.2, 0.3])


def test_attached_containers_talk_over_localhost(engine: Any, image: str) -> None:
    server = ContainerComponent(
        image,
        "python -m multicosim.docker._selftest localhost-server",
        name="server",
        ready="started",
    )
    relay = ContainerFirmwareComponent(
        image=image,
        command=SERVE.format("relay"),
        msgtype=st.Echo,
        replytype=st.EchoReply,
        name="relay",
    )
    # The same relay on the network but outside the shared stack cannot see the server.
    outsider = ContainerFirmwareComponent(
        image=image,
        command=SERVE.format("relay"),
        msgtype=st.Echo,
        replytype=st.EchoReply,
        name="outsider",
        env={"MCS_SELFTEST_TIMEOUT_MS": "500"},
    )
    sim = ContainerSimulator()
    group = sim.add(AttachedComponent(relay, [server]))
    alone = sim.add(outsider)
    with sim.start() as simulation:
        attached = simulation.get(group)
        assert attached.name == "relay"
        reply = attached.host.send(st.Echo("over localhost"))
        assert reply.text.endswith("says over localhost")
        (server_node,) = attached.attached
        info = engine.api.inspect_container(server_node.id)
        assert info["HostConfig"]["NetworkMode"] == f"container:{attached.host.container.id}"
        assert info["Config"]["Labels"]["multicosim.run"] == simulation.run_id
        with pytest.raises(mcs.RemoteError, match="nothing answers on localhost"):
            simulation.get(alone).send(st.Echo("from outside"))
        assert len(simulation.containers()) == 3


def test_container_component_publishes_ports_on_loopback(engine: Any, image: str) -> None:
    import zmq

    from multicosim.core import wire

    sim = ContainerSimulator()
    nid = sim.add(ContainerComponent(image, SERVE.format("echo").format(port=6000), ports=[6000]))
    with sim.start() as simulation:
        node = simulation.get(nid)
        assert node.name == "echo"
        port = node.host_port(6000)
        assert node.host_port("6000/tcp") == port
        sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.DEALER)
        sock.setsockopt(zmq.LINGER, 0)
        # A firmware in a simulation answers only callers that present its component's token.
        token = simulation.environment.coordinator.token("echo")
        sock.setsockopt(zmq.ROUTING_ID, token.encode())
        try:
            sock.connect(f"tcp://127.0.0.1:{port}")
            sock.send(wire.encoder.encode(wire.Ping(1)))
            assert sock.poll(5000)
            pong = wire.from_firmware.decode(sock.recv())
        finally:
            sock.close(0)
        assert pong == wire.Pong(1, "echo", "Echo")
        with pytest.raises(mcs.ConfigurationError, match="container_port"):
            node.host_port(6001)


def test_mounts_are_read_only_in_the_container(engine: Any, image: str) -> None:
    # The container's user is none of this machine's: what it reads must be readable by all
    # (pytest's own temporary directories are not).
    with tempfile.TemporaryDirectory() as name:
        shared = Path(name)
        shared.chmod(0o755)
        (shared / "model.txt").write_text("from the host\n")
        (shared / "model.txt").chmod(0o644)
        script = "cat /data/model.txt; touch /data/written 2>/dev/null || echo read-only; sleep 60"
        sim = ContainerSimulator()
        component = ContainerComponent(
            image, ["sh", "-c", script], name="reader", ready="started", mounts={name: "/data"}
        )
        nid = sim.add(component)
        with sim.start() as simulation:
            node = simulation.get(nid)
            (mount,) = engine.api.inspect_container(node.id)["Mounts"]
            assert (mount["Source"], mount["Destination"], mount["RW"]) == (name, "/data", False)
            # The program reads what the host holds, and cannot write there.
            for _ in range(200):
                if "read-only" in node.logs():
                    break
                time.sleep(0.05)
            assert node.logs().splitlines()[:2] == ["from the host", "read-only"]
        assert not (shared / "written").exists()


def test_run_dir_keeps_container_logs(engine: Any, image: str, tmp_path: Path) -> None:
    sim = ContainerSimulator(run_dir=tmp_path)
    fw = sim.add(echo(image))
    with sim.start() as simulation:
        simulation.get(fw).send(st.Echo("x"))
    log = (simulation.run_dir / "echo.log").read_text()
    assert "serving Firmware('echo'" in log


def test_several_simulations_side_by_side(engine: Any, image: str) -> None:
    sims = []
    try:
        for _ in range(3):
            sim = ContainerSimulator()
            sims.append((sim.add(echo(image)), sim.start()))
        assert len({s.network for _, s in sims}) == 3
        assert [s.get(fid).send(st.Echo("x")).text for fid, s in sims] == ["x"] * 3
    finally:
        for _, s in sims:
            s.stop()


def test_container_node_manages_a_container_it_is_given(engine: Any, image: str) -> None:
    from multicosim.docker.engine import NotFound, labels

    container = engine.containers.run(
        image, ["sleep", "60"], detach=True, init=True, labels=labels("test-given")
    )
    node = ContainerNode(container, stop_timeout=1)
    assert node.name == container.name
    assert node.poll() is None
    node.stop()
    node.stop()
    with pytest.raises(NotFound):
        engine.api.inspect_container(container.id)
