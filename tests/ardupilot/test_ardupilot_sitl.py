"""Real ArduPilot SITL on our worlds: flights, its log, isolation, crashes, containers.

These need ArduPilot's SITL directory (``--mcs-ardupilot-dir`` or ``MCS_ARDUPILOT_DIR``;
CI gives ../shared/ardupilot-sitl) and skip with the reason where none is configured.
"""

from __future__ import annotations

import itertools
import math
import os
import signal
import socket
import struct
from pathlib import Path
from typing import Any

import pytest
from ardupilot_helpers import wp

import multicosim as mcs
import multicosim.ardupilot as ardupilot
from multicosim.ardupilot._bridge import process_ports
from multicosim.core.geo import LocalProjection
from multicosim.docker import ContainerNode, ContainerSimulation

pytestmark = pytest.mark.usefixtures("no_leaks")

mavutil = pytest.importorskip("pymavlink.mavutil")


def short_flight(home: ardupilot.Home) -> ardupilot.Configuration:
    """Take off to 8 m, fly 15 m north, land there."""
    return ardupilot.Configuration([wp(home, 15, 0, 8)], end="land", time_limit=200.0)


def listening(pid: int) -> list[str]:
    """The TCP sockets process ``pid`` listens on (state 0A in /proc/net/tcp)."""
    inodes = set()
    for fd in os.scandir(f"/proc/{pid}/fd"):
        target = os.readlink(fd.path)
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    out = []
    for proto in ("tcp", "tcp6"):
        for line in Path(f"/proc/{pid}/net/{proto}").read_text().splitlines()[1:]:
            fields = line.split()
            if fields[9] in inodes and fields[3] == "0A":
                out.append(fields[1])
    return out


def test_arducopter_flies_a_mission_deaf_to_rc_input_and_leaves_its_dataflash_log(
    ardupilot_dir: str,
) -> None:
    # ArduPilot's simulated RC receiver is a UDP socket on all interfaces. Anyone may send
    # it channels: here flight mode switch low (CIRCLE in ArduCopter's defaults), throttle
    # up, sticks over, from before arming to the landing, to every UDP socket it holds.
    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir)
    target: dict[str, list[int]] = {}
    sent = []
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    class Hostile:
        period = 0.02

        def setup(self, ctx: Any) -> None:
            pass

        def step(self, ctx: Any) -> None:
            if ctx.time >= 30.0:
                channels = [1900, 1100, 1800, 1900, 1000, 1000, 2000, 2000] + [1500] * 8
                for port in target.get("ports", []):
                    sock.sendto(struct.pack("<16H", *channels), ("127.0.0.1", port))
                    sent.append(port)

    simulator.add(mcs.InProcessComponent(Hostile, "hostile"))
    with sock, simulator.start() as simulation:
        pid = simulation.firmware.firmware_nodes.pid
        assert pid is not None
        target["ports"] = sorted(p for proto, p in process_ports(pid) if proto == "udp")
        home = simulation.home
        result = simulation.firmware.send(short_flight(home))
        logs = simulation.flight_logs()
        assert logs, "ArduCopter left no DataFlash log"
        log = mavutil.mavlink_connection(str(logs[-1]))
        texts, frame_type, top = [], None, 0.0
        while (m := log.recv_match(type=["MSG", "PARM", "CTUN"])) is not None:
            if m.get_type() == "MSG":
                texts.append(m.Message)
            elif m.get_type() == "PARM" and m.Name == "FRAME_TYPE":
                frame_type = m.Value
            elif m.get_type() == "CTUN":
                top = max(top, m.Alt)
        log.close()
    assert result.completed, result.reason
    assert result.firmware_version == "4.5.6"
    assert [r.index for r in result.reached] == [0]
    assert result.landed
    assert not result.armed
    proj = LocalProjection(home.lat, home.lon)
    last = result.trajectory[-1]
    north, east = proj.project(last.true_lat, last.true_lon)
    assert math.hypot(north - 15, east) < 2.0 + 1.5
    # The RC input reached it all along and changed nothing.
    assert len(target["ports"]) >= 2
    assert set(sent) == set(target["ports"])
    modes = [m for m, _ in itertools.groupby(s.mode for s in result.trajectory if s.armed)]
    assert modes == ["GUIDED", "AUTO"]
    assert not [m for m in result.messages if m.startswith("RC")]
    # The DataFlash log is ArduCopter's own record of the flight: read back, it names the
    # firmware, the frame it was told, and it saw the climb the world made.
    assert any(t.startswith("ArduCopter V4.5.6") for t in texts)
    assert frame_type == 1  # quad X
    assert top == pytest.approx(8.0, abs=1.0)


def test_arducopter_listens_on_no_port_and_stops_cleanly(ardupilot_dir: str) -> None:
    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir)
    simulation = simulator.start()
    try:
        # Past ArduCopter's setup (it waits 2 s for the RC input it ignores): from there on it
        # handles SIGTERM, finishing its log.
        simulation.advance(5.0)
        autopilot = simulation.firmware.firmware_nodes
        program, pid, instance = autopilot.program, autopilot.pid, simulation.firmware.instance
        assert program is not None
        assert pid is not None
        assert listening(pid) == []
        ports = process_ports(pid)
        well_known = {5760 + 10 * instance + k for k in range(4)} | {5501 + 10 * instance}
        assert not {port for _, port in ports} & well_known
        # Its MAVLink link is a connection to the simulation, its physics an answered socket.
        assert autopilot.bridge is not None
        assert ("tcp", autopilot.bridge.mavlink_port) not in ports
    finally:
        simulation.stop()
    assert program.poll() == 0, "ArduCopter did not exit on SIGTERM"
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_two_arducopters_fly_side_by_side(ardupilot_dir: str) -> None:
    with (
        ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir, seed=1).start() as one,
        ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir, seed=2).start() as two,
    ):
        instances = {one.firmware.instance, two.firmware.instance}
        workdirs = {sim.firmware.firmware_nodes.workdir for sim in (one, two)}
        results = [sim.firmware.send(short_flight(sim.home)) for sim in (one, two)]
        # Each wrote its parameters and its log in its own working directory.
        for workdir in workdirs:
            assert workdir is not None
            assert (workdir / "eeprom.bin").is_file()
            assert list((workdir / "logs").glob("*.BIN"))
    assert len(instances) == 2
    assert len(workdirs) == 2
    for result in results:
        assert result.completed, result.reason


def test_arducopter_dying_mid_flight_is_reported_with_its_output(ardupilot_dir: str) -> None:
    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir)
    victim: dict[str, int] = {}

    class KillAt:
        period = 0.1

        def setup(self, ctx: Any) -> None:
            pass

        def step(self, ctx: Any) -> None:
            if ctx.time >= 5.0 and victim.get("pid"):
                os.killpg(victim.pop("pid"), signal.SIGKILL)

    simulator.add(mcs.InProcessComponent(KillAt, "killer"))
    with simulator.start() as simulation:
        pid = simulation.firmware.firmware_nodes.pid
        assert pid is not None
        victim["pid"] = pid
        with pytest.raises(mcs.NodeCrashedError) as info:
            simulation.firmware.send(short_flight(simulation.home))
    assert info.value.name == "ardupilot"
    assert info.value.exit_code == -signal.SIGKILL
    assert "Starting sketch 'ArduCopter'" in info.value.log_tail


def test_arducopter_flies_in_a_container_on_the_simulation_network(
    ardupilot_dir: str, mcs_runtime_image: str
) -> None:
    simulator = ardupilot.ArduCopter(
        fidelity="medium", firmware_dir=ardupilot_dir, placement="docker"
    )
    with simulator.start() as simulation:
        container = simulation.firmware.firmware_nodes.program
        assert isinstance(container, ContainerNode)
        container.container.reload()
        attrs = container.container.attrs
        result = simulation.firmware.send(short_flight(simulation.home))
        logs = simulation.flight_logs()
        assert logs
        assert logs[-1].suffix == ".BIN"
        assert logs[-1].stat().st_size > 0
    assert result.completed, result.reason
    assert result.firmware_version == "4.5.6"
    # Nothing of it is published on the host; it is on the simulation's own network.
    assert not any(attrs["HostConfig"].get("PortBindings") or {})
    inner = simulation.simulation
    assert isinstance(inner, ContainerSimulation)
    assert list(attrs["NetworkSettings"]["Networks"]) == [inner.network]
    assert attrs["Config"]["Labels"]["multicosim.run"] == inner.run_id
