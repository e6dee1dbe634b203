"""ArduPilot's JSON physics interface and launch against a stand-in SITL program.

The stand-in (``standin.py``) speaks ArduPilot's side of the protocol: it connects its
MAVLink link out to the simulation, sends servo packets and blocks for the JSON answers,
and can misbehave on purpose. Everything here runs without ArduPilot.
"""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from ardupilot_helpers import fake_ardupilot

import multicosim as mcs
import multicosim.ardupilot as ardupilot
from multicosim.ardupilot._bridge import ServoOutputs
from multicosim.mavlink.dialect import new_link
from multicosim.mavlink.hil import MavlinkPacket, Truth

pytestmark = pytest.mark.usefixtures("no_leaks")


def received(simulation: ardupilot.ArduPilotSimulation) -> list[dict[str, Any]]:
    """What the stand-in received (its ``standin.jsonl``)."""
    workdir = simulation.firmware.firmware_nodes.workdir
    assert workdir is not None
    return [json.loads(line) for line in (workdir / "standin.jsonl").read_text().splitlines()]


class Probe:
    """Records what is published on a topic, with the simulated time."""

    def __init__(self, topic: str, tp: type[Any], period: float = 0.0025) -> None:
        self.topic, self.type, self.period = topic, tp, period
        self.messages: list[tuple[float, Any]] = []

    def setup(self, ctx: mcs.StepContext) -> None:
        self.sub = ctx.subscribe(self.topic, self.type)

    def step(self, ctx: mcs.StepContext) -> None:
        self.messages.extend((ctx.time, m) for m in self.sub.messages)


def probe(simulator: Any, topic: str, tp: type[Any], name: str) -> Probe:
    recorder = Probe(topic, tp)
    simulator.add(mcs.InProcessComponent(lambda: recorder, name))
    return recorder


# -- lockstep -----------------------------------------------------------------------------------


def test_the_bridge_steps_the_world_in_lockstep_with_arducopters_frames(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "climb")))
    truth = probe(simulator, "ardupilot/truth", Truth, "truth-probe")
    servos = probe(simulator, "ardupilot/servos", ServoOutputs, "servo-probe")
    with simulator.start() as simulation:
        simulation.advance(2.0)
        bridge = simulation.firmware.firmware_nodes.bridge
        assert bridge is not None
        frames = bridge.frames
        standin = received(simulation)
    states = [r["state"] for r in standin if "state" in r]
    # One answer per frame, stamped with the simulated time, one 2.5 ms frame apart.
    assert frames == len(states) >= 799
    stamps = [s["timestamp"] for s in states]
    assert stamps == pytest.approx([stamps[0] + 0.0025 * i for i in range(len(stamps))])
    # The first answer is the vehicle standing: level (facing east, MuJoCo's x axis),
    # specific force about straight up (it settles on its legs).
    first = states[0]
    w, x, y, z = first["quaternion"]
    assert (x, y) == (pytest.approx(0, abs=1e-6), pytest.approx(0, abs=1e-6))
    assert math.degrees(math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))) == pytest.approx(
        90
    )
    ax, ay, az = first["imu"]["accel_body"]
    assert az < -9.0
    assert math.hypot(ax, ay) < 0.2 * abs(az)
    assert first["position"] == pytest.approx([0, 0, 0], abs=0.01)
    # Every packet's outputs reached the world, and full throttle lifted the quadrotor.
    assert [m.pwm[:4] for _, m in servos.messages[:3]] == [(2000,) * 4] * 3
    # (The probe steps before the bridge: the last instant's outputs are not seen yet.)
    assert [m.frame_count for _, m in servos.messages] == list(range(1, frames))
    assert truth.messages[-1][1].alt > 1.0
    # What the world sent ArduPilot is the truth it published in the same instant.
    last = states[-1]
    by_time = {round(t, 6): m for t, m in truth.messages}
    sent = by_time[round(last["timestamp"], 6)]
    assert last["position"] == pytest.approx([sent.north, sent.east, sent.down])


def test_a_repeated_frame_is_answered_again_without_advancing(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "resend")))
    with simulator.start() as simulation:
        simulation.advance(0.5)
        bridge = simulation.firmware.firmware_nodes.bridge
        assert bridge is not None
        resends = bridge.resends
        standin = received(simulation)
    answers = [r for r in standin if r.get("frame") == 20]
    assert resends == 1
    assert len(answers) == 2
    assert answers[0]["raw"] == answers[1]["raw"]  # the same state, the same time
    nxt = next(r for r in standin if r.get("frame") == 21)
    assert nxt["state"]["timestamp"] == pytest.approx(answers[0]["state"]["timestamp"] + 0.0025)


def test_packets_resent_while_the_simulation_paused_are_answered_once(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "climb")))
    with simulator.start() as simulation:
        simulation.advance(0.1)
        time.sleep(2.5)  # the simulation is paused: the stand-in resends its packet twice
        simulation.advance(0.1)
        time.sleep(2.5)
        simulation.advance(0.1)
        bridge = simulation.firmware.firmware_nodes.bridge
        assert bridge is not None
        stale, resends = bridge.stale, bridge.resends
        standin = received(simulation)
    assert stale >= 4
    assert resends == 0
    # One answer per frame, each frame's own: no answer was read a frame late.
    frames = [r["frame"] for r in standin if "frame" in r]
    assert frames == list(range(len(frames)))
    stamps = [r["state"]["timestamp"] for r in standin if "state" in r]
    assert stamps == pytest.approx([stamps[0] + 0.0025 * i for i in range(len(stamps))])


def test_arducopter_restarting_is_an_error_naming_it(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "restart")))
    with simulator.start() as simulation, pytest.raises(mcs.NodeCrashedError) as info:
        simulation.advance(1.0)
    assert info.value.name == "ardupilot"
    assert "restarted: its frame count went back from 50 to 0" in str(info.value)
    assert "stand-in: rebooting" in info.value.log_tail


def test_arducopter_dying_mid_run_is_reported_with_its_exit_code(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "crash")))
    with simulator.start() as simulation, pytest.raises(mcs.NodeCrashedError) as info:
        simulation.advance(1.0)
    assert info.value.name == "ardupilot"
    assert info.value.exit_code == 7
    assert "crashing on purpose" in info.value.log_tail


# -- start errors -------------------------------------------------------------------------------


def test_a_firmware_that_exits_at_start_is_named_with_its_output(tmp_path: Path) -> None:
    simulator = ardupilot.ArduRover(firmware_dir=str(fake_ardupilot(tmp_path, "exit")))
    with pytest.raises(mcs.NodeStartError) as info:
        simulator.start()
    assert info.value.name == "ardupilot"
    assert info.value.exit_code == 1
    assert "exited before it could send a servo packet" in str(info.value)
    assert "Address already in use" in info.value.log_tail


def test_a_firmware_that_never_sends_a_servo_packet_times_out(tmp_path: Path) -> None:
    firmware = ardupilot.SITL(directory=str(fake_ardupilot(tmp_path, "silent")), start_timeout=1.5)
    with pytest.raises(mcs.NodeStartError) as info:
        ardupilot.ArduCopter(firmware=firmware).start()
    assert "did not send a servo packet to its simulator" in str(info.value)
    assert "start-up limit of 1.5 s" in str(info.value)
    assert "waiting for nothing" in info.value.log_tail


def test_a_firmware_that_never_speaks_mavlink_fails_to_start(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "mute")))
    with pytest.raises(mcs.NodeStartError) as info:
        simulator.start()
    assert info.value.name == "ardupilot"
    assert "sent no MAVLink within 10 simulated seconds" in str(info.value)
    assert "stand-in ArduPilot (mute)" in info.value.log_tail


# -- the MAVLink link, and traffic from elsewhere ---------------------------------------------


def test_the_link_carries_mavlink_both_ways_and_strangers_are_ignored(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "climb")))
    down = probe(simulator, "ardupilot/mavlink/down", MavlinkPacket, "down-probe")

    class Sender:
        period = 0.05

        def setup(self, ctx: mcs.StepContext) -> None:
            self.mav = new_link(255, 190)

        def step(self, ctx: mcs.StepContext) -> None:
            msg = self.mav.command_long_encode(1, 1, 512, 0, 148, 0, 0, 0, 0, 0, 0)
            ctx.publish("ardupilot/mavlink/up", MavlinkPacket(bytes(msg.pack(self.mav))))

    simulator.add(mcs.InProcessComponent(Sender, "sender"))
    with simulator.start() as simulation:
        bridge = simulation.firmware.firmware_nodes.bridge
        assert bridge is not None
        simulation.advance(0.2)
        # A stranger's servo packets and a stranger's MAVLink client change nothing.
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
            fake = struct.pack("<HHI16H", 18458, 400, 10_000, *([1000] * 16))
            for _ in range(20):
                stranger.sendto(fake, ("127.0.0.1", bridge.physics_port))
                stranger.sendto(b"\x00garbage", ("127.0.0.1", bridge.physics_port))
        # ArduPilot's link is up: nothing listens for another.
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", bridge.mavlink_port), timeout=5)
        simulation.advance(0.6)
        ignored = bridge.ignored
        standin = received(simulation)
    assert ignored == 40
    heartbeats = [
        m
        for _, p in down.messages
        for m in new_link(0, 0).parse_buffer(p.data) or ()
        if m.get_type() == "HEARTBEAT"
    ]
    assert [m.custom_mode for m in heartbeats] == [0] * len(heartbeats)  # the stand-in's only
    assert len(heartbeats) >= 3
    assert {"uplink": "COMMAND_LONG"} in standin
    # The stranger's packets never reached the world: the frames stayed in order.
    frames = [r["frame"] for r in standin if "frame" in r]
    assert frames == list(range(len(frames)))


def test_stopping_leaves_nothing_behind(tmp_path: Path) -> None:
    simulator = ardupilot.ArduCopter(firmware_dir=str(fake_ardupilot(tmp_path, "climb")))
    simulation = simulator.start()
    simulation.advance(0.1)
    node = simulation.firmware.firmware_nodes
    bridge, program, pid = node.bridge, node.program, node.pid
    assert bridge is not None
    assert program is not None
    assert pid is not None
    port = bridge.physics_port
    simulation.stop()
    simulation.stop()  # idempotent
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as again:
        again.bind(("127.0.0.1", port))
    deadline = time.monotonic() + 5
    while program.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert program.poll() is not None


def test_only_the_firmwares_own_sockets_are_answered() -> None:
    from multicosim.ardupilot._bridge import JsonBridge
    from multicosim.ardupilot.launch import _owned_by

    physics = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    physics.bind(("127.0.0.1", 0))
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.bind(("127.0.0.1", 0))
    listener.listen(4)
    bridge = JsonBridge(
        name="ardupilot", period=0.0025, physics=physics, mavlink=listener,
        truth="t", servos="s", uplink="u", downlink="d",
    )  # fmt: skip
    packet = struct.pack("<HHI16H", 18458, 400, 0, *([1000] * 16))
    try:
        with (
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp,
            socket.create_connection(("127.0.0.1", bridge.mavlink_port), timeout=5) as tcp,
        ):
            # Sockets of another process (pid 1) are ArduPilot's: ours are strangers'.
            bridge.peer_check = _owned_by(1)
            udp.sendto(packet, ("127.0.0.1", bridge.physics_port))
            time.sleep(0.1)
            assert not bridge.poll_started()
            assert bridge.ignored == 1
            assert tcp.recv(1) == b"", "a stranger's MAVLink client was kept"
            # The same traffic from sockets the firmware's process holds is taken.
            bridge.peer_check = _owned_by(os.getpid())
            udp.sendto(packet, ("127.0.0.1", bridge.physics_port))
            time.sleep(0.1)
            assert bridge.poll_started()
    finally:
        bridge.close()


def test_arducopter_does_not_outlive_a_killed_simulation(tmp_path: Path) -> None:
    directory = fake_ardupilot(tmp_path / "ardupilot", "climb")
    program = (
        "import sys, time, multicosim.ardupilot as a\n"
        f"sim = a.ArduCopter(firmware_dir={str(directory)!r}).start()\n"
        "sim.advance(0.1)\n"
        "print(sim.firmware.firmware_nodes.pid, flush=True)\n"
        "time.sleep(120)\n"
    )
    host = subprocess.Popen(
        [sys.executable, "-c", program], stdout=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        assert host.stdout is not None
        firmware = int(host.stdout.readline())
        os.kill(host.pid, signal.SIGKILL)  # no cleanup of any kind
        host.wait(10)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                os.kill(firmware, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            os.kill(firmware, signal.SIGKILL)
            pytest.fail("the firmware outlived the simulation that started it")
    finally:
        if host.poll() is None:
            os.killpg(host.pid, signal.SIGKILL)
            host.wait(10)
        assert host.stdout is not None
        host.stdout.close()


def test_missions_are_checked_before_they_are_flown(tmp_path: Path) -> None:
    with ardupilot.ArduRover(firmware_dir=str(fake_ardupilot(tmp_path, "climb"))).start() as sim:
        near = ardupilot.Waypoint(sim.home.lat + 1e-4, sim.home.lon, 0.0)
        with pytest.raises(mcs.ConfigurationError, match=r"cruise_speed=12.*top speed"):
            sim.firmware.send(ardupilot.Configuration([near], cruise_speed=12.0))
        far = ardupilot.Waypoint(sim.home.lat + 0.1, sim.home.lon, 0.0)  # 11 km north
        with pytest.raises(mcs.ConfigurationError, match="geofence"):
            sim.firmware.send(ardupilot.Configuration([far]))
        with pytest.raises(mcs.MessageTypeError):
            sim.firmware.send("fly")  # type: ignore[arg-type]
