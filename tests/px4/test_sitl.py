"""Real PX4 SITL flying our world: its simulator interface, the launch, errors and evidence.

The flights need a PX4 SITL binary (``--mcs-px4-binary`` or ``MCS_PX4_BINARY``; CI gives
the one in ../shared/px4-sitl) and skip with the reason where none is configured. The rest
runs everywhere: the bridge against a MAVLink peer that behaves like PX4's
simulator_mavlink, and the launch errors against stand-in ``px4`` programs.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.hil import Truth, Wire
from multicosim.mavlink.udp import API_PORT
from multicosim.px4.scenario import WorldComponent
from multicosim.px4.simulator import HIL_CLOCK_START_US, HilTcpBridge
from multicosim.px4.sitl import API_LOCAL_PORT, claim_instance
from multicosim.quadrotor.topics import world_topics
from pytest_multicosim.px4 import RealPX4

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


def fake_px4(tmp_path: Path, script: str) -> Path:
    """A stand-in PX4 directory: ``bin/px4`` runs ``script``; ``etc`` has rcS and none_iris."""
    (tmp_path / "bin").mkdir()
    binary = tmp_path / "bin" / "px4"
    binary.write_text("#!/bin/sh\n" + script + "\n")
    binary.chmod(0o755)
    airframes = tmp_path / "etc" / "init.d-posix" / "airframes"
    airframes.mkdir(parents=True)
    (tmp_path / "etc" / "init.d-posix" / "rcS").write_text("#!/bin/sh\n")
    (airframes / "10016_none_iris").write_text("#!/bin/sh\n")
    return binary


# -- configuration, refused before anything starts -------------------------------------------


def test_sitl_needs_a_binary_or_an_image() -> None:
    with pytest.raises(mcs.ConfigurationError, match="firmware"):
        px4.SITL()


def test_sitl_refuses_a_missing_binary(tmp_path: Path) -> None:
    with pytest.raises(mcs.ConfigurationError, match=r"binary=.*an existing file"):
        px4.SITL(binary=str(tmp_path / "nowhere" / "px4"))


def test_sitl_refuses_a_file_that_is_not_executable(tmp_path: Path) -> None:
    binary = fake_px4(tmp_path, "exit 0")
    binary.chmod(0o644)
    with pytest.raises(mcs.ConfigurationError, match="an executable file"):
        px4.SITL(binary=str(binary))


def test_sitl_refuses_a_binary_without_its_etc_directory(tmp_path: Path) -> None:
    binary = fake_px4(tmp_path, "exit 0")
    (tmp_path / "etc" / "init.d-posix" / "rcS").unlink()
    with pytest.raises(mcs.ConfigurationError, match=r"etc=.*init.d-posix/rcS"):
        px4.SITL(binary=str(binary))


def test_sitl_refuses_an_unknown_airframe(tmp_path: Path) -> None:
    binary = fake_px4(tmp_path, "exit 0")
    with pytest.raises(mcs.ConfigurationError, match="model='gz_x500'"):
        px4.SITL(binary=str(binary), model="gz_x500")


@pytest.mark.parametrize(
    ("params", "field"),
    [({"mpc_xy_cruise": 5.0}, "params"), ({"MPC_XY_CRUISE": math.nan}, "params['MPC_XY_CRUISE']")],
)
def test_sitl_refuses_bad_parameters(tmp_path: Path, params: dict[str, float], field: str) -> None:
    binary = fake_px4(tmp_path, "exit 0")
    with pytest.raises(mcs.ConfigurationError) as info:
        px4.SITL(binary=str(binary), params=params)
    assert info.value.field == field


def test_real_px4_does_not_fly_the_point_mass(tmp_path: Path) -> None:
    sitl = px4.SITL(binary=str(fake_px4(tmp_path, "exit 0")))
    with pytest.raises(mcs.ConfigurationError, match=r"fidelity='low'.*medium"):
        px4.PX4(fidelity="low", firmware=sitl)


def test_an_image_runs_in_the_docker_placement_only() -> None:
    with pytest.raises(mcs.ConfigurationError, match="placement='docker'") as info:
        px4.PX4(fidelity="medium", firmware=px4.SITL(image="multicosim/px4-sitl:0.1.0"))
    assert info.value.field == "firmware"
    assert "'process'" in str(info.value)


# -- the simulator interface -----------------------------------------------------------------


class FakeSimulatorClient(threading.Thread):
    """Connects like PX4 SITL and answers every IMU sample with fixed motor outputs."""

    def __init__(self, port: int, throttle: float, garbage_first: bool = False) -> None:
        super().__init__(name="px4-like", daemon=True)
        self.port, self.throttle, self.garbage_first = port, throttle, garbage_first
        self.stop = threading.Event()
        self.imu = 0
        self.gps_fix = 0
        self.ground_truth = 0
        self.first_time: int | None = None
        self.error: BaseException | None = None

    def run(self) -> None:
        try:
            from pymavlink.dialects.v20 import common

            mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
            with socket.create_connection(("127.0.0.1", self.port), timeout=5) as sock:
                sock.settimeout(0.2)
                # As PX4 does: a heartbeat, then the request for ground truth.
                sock.sendall(mav.heartbeat_encode(2, 12, 0, 0, 0).pack(mav))
                ask = mav.command_long_encode(0, 0, 511, 0, 115, 50_000, 0, 0, 0, 0, 0)
                sock.sendall(ask.pack(mav))
                while not self.stop.is_set():
                    try:
                        data = sock.recv(65536)
                    except TimeoutError:
                        continue
                    if not data:
                        return
                    for m in mav.parse_buffer(data) or ():
                        kind = m.get_type()
                        if kind == "HIL_GPS":
                            self.gps_fix = m.fix_type
                        elif kind == "HIL_STATE_QUATERNION":
                            self.ground_truth += 1
                        elif kind == "HIL_SENSOR" and m.fields_updated & 0x3F == 0x3F:
                            if self.first_time is None:
                                self.first_time = m.time_usec
                            self.imu += 1
                            controls = [self.throttle] * 4 + [0.0] * 12
                            out = mav.hil_actuator_controls_encode(m.time_usec, controls, 129, 1)
                            sock.sendall(out.pack(mav))
        except BaseException as exc:
            self.error = exc


@pytest.mark.parametrize(("placement", "wire"), [("in-process", "native"), ("process", "mavlink")])
def test_bridge_runs_the_world_in_lockstep_with_a_tcp_simulator_client(
    placement: str, wire: Wire
) -> None:
    world = px4.WorldConfig(period=0.004)
    topics = world_topics(world)
    sim = mcs.ProcessSimulator(seed=0)
    sim.add(WorldComponent(world, "medium", placement=placement, wire=wire))
    bridge_id = sim.add(
        mcs.InProcessComponent(
            lambda: HilTcpBridge(
                topics, home_alt=world.home.alt, period=world.period, port=0, wire=wire
            ),
            "hil",
        )
    )
    truth: list[Truth] = []

    class Recorder:
        period = 0.05

        def setup(self, ctx: Any) -> None:
            self.sub = ctx.subscribe(topics.truth, Truth)

        def step(self, ctx: Any) -> None:
            truth.extend(self.sub.messages)

    sim.add(mcs.InProcessComponent(Recorder, "recorder"))
    with sim.start() as simulation:
        bridge: HilTcpBridge = simulation.get(bridge_id).participant
        client = FakeSimulatorClient(bridge.port, throttle=0.7)
        client.start()
        deadline = time.monotonic() + 10
        while not bridge.connected and time.monotonic() < deadline:
            simulation.advance(world.period)
        assert bridge.connected
        simulation.advance(2.0)
        client.stop.set()
        client.join(5)
    assert client.error is None, client.error
    # Every step answered (lockstep); PX4's clock starts a second in, as under Gazebo.
    assert bridge.steps == bridge.replies > 400
    assert client.imu >= bridge.steps
    assert client.first_time is not None
    assert HIL_CLOCK_START_US < client.first_time < HIL_CLOCK_START_US + 10_000_000
    assert client.gps_fix == 3
    assert client.ground_truth > 10, "HIL_STATE_QUATERNION was asked for and not sent"
    assert truth[-1].alt > 1.0, "70 % throttle did not lift the quadrotor"
    n, e = PROJ.project(truth[-1].lat, truth[-1].lon)
    assert math.hypot(n, e) < 1.0


def test_bridge_drops_a_client_that_speaks_no_mavlink() -> None:
    world = px4.WorldConfig(period=0.004)
    sim = mcs.ProcessSimulator(seed=0)
    sim.add(WorldComponent(world, "medium", placement="in-process", wire="native"))
    bridge_id = sim.add(
        mcs.InProcessComponent(
            lambda: HilTcpBridge(
                world_topics(world),
                home_alt=world.home.alt,
                period=world.period,
                port=0,
                wire="native",
            ),
            "hil",
        )
    )
    with sim.start() as simulation:
        bridge: HilTcpBridge = simulation.get(bridge_id).participant
        with socket.create_connection(("127.0.0.1", bridge.port), timeout=5) as intruder:
            intruder.sendall(b"GET / HTTP/1.0\r\n\r\n" + bytes(range(256)) * 3)
            simulation.advance(0.1)  # the bridge looks at its clients when it steps
            assert intruder.recv(1) == b"", "the bridge kept a client that spoke no MAVLink"
        assert not bridge.connected
        client = FakeSimulatorClient(bridge.port, throttle=0.0)
        client.start()
        deadline = time.monotonic() + 10
        while not bridge.connected and time.monotonic() < deadline:
            simulation.advance(world.period)
        simulation.advance(0.5)
        client.stop.set()
        client.join(5)
    assert client.error is None, client.error
    assert bridge.replies > 50


def test_claimed_instances_skip_ports_in_use() -> None:
    first, held = claim_instance()
    with held, contextlib.ExitStack() as stack:
        # Hold the API port of a free instance after it (other runs may hold some already).
        for taken in range(first + 1, first + 20):
            api = stack.enter_context(socket.socket(socket.AF_INET, socket.SOCK_DGRAM))
            try:
                api.bind(("127.0.0.1", API_LOCAL_PORT + taken))
                break
            except OSError:
                continue
        second, other = claim_instance()
        other.close()
    # Neither the instance whose simulator port is held nor the one whose API port is.
    assert second not in (first, taken)


# -- the launch's errors -------------------------------------------------------------------------


def test_px4_that_exits_at_start_is_named_with_its_exit_code_and_output(tmp_path: Path) -> None:
    sitl = px4.SITL(binary=str(fake_px4(tmp_path, 'echo "ERROR [px4] no rootfs"; exit 3')))
    simulator = px4.PX4(fidelity="medium", firmware=sitl)
    with pytest.raises(mcs.NodeStartError) as info:
        simulator.start()
    assert info.value.name == "px4"
    assert info.value.exit_code == 3
    assert "no rootfs" in info.value.log_tail
    assert "before it could connect to its simulator" in str(info.value)


def test_px4_that_never_connects_fails_after_its_start_timeout(tmp_path: Path) -> None:
    binary = fake_px4(tmp_path, 'echo "waiting forever"; exec sleep 60')
    simulator = px4.PX4(fidelity="medium", firmware=px4.SITL(binary=str(binary), start_timeout=1.5))
    with pytest.raises(mcs.NodeStartError) as info:
        simulator.start()
    assert "did not connect to its simulator" in str(info.value)
    assert "start-up limit of 1.5 s" in str(info.value)
    assert "waiting forever" in info.value.log_tail


# -- real PX4 ------------------------------------------------------------------------------------


def test_real_px4_flies_a_mission_and_leaves_its_flight_log(
    px4_sitl: RealPX4, tmp_path: Path
) -> None:
    from pyulog import ULog

    simulator = px4.PX4(fidelity="medium", firmware=px4_sitl.sitl())
    config = px4.Configuration([wp(30, 0, 12), wp(30, 30, 15)], end="land", time_limit=300.0)
    with simulator.start() as simulation:
        result = simulation.firmware.send(config)
        logs = simulation.flight_logs()
        ulog = ULog(str(logs[-1])) if logs else None
    assert result.completed, result.reason
    assert result.firmware_version == "1.15.4"
    assert [r.index for r in result.reached] == [0, 1]
    assert result.landed
    assert not result.armed
    n, e = PROJ.project(result.trajectory[-1].true_lat, result.trajectory[-1].true_lon)
    assert math.hypot(n - 30, e - 30) < 3.0
    # The ULog is PX4's own record of the flight: read back, it says what the world says.
    assert ulog is not None, "PX4 left no ULog"
    assert ulog.msg_info_dict["ver_sw_release"] >> 8 == 0x01_0F_04  # v1.15.4
    position = ulog.get_dataset("vehicle_local_position")
    assert min(position.data["z"]) == pytest.approx(-15.0, abs=1.5)


def test_real_px4_dying_mid_flight_is_reported_with_its_output(px4_sitl: RealPX4) -> None:
    simulator = px4.PX4(fidelity="medium", firmware=px4_sitl.sitl())
    killer: dict[str, int] = {}

    class KillAt:
        period = 0.1

        def setup(self, ctx: Any) -> None:
            pass

        def step(self, ctx: Any) -> None:
            if ctx.time >= 15.0 and killer.get("pid"):
                os.killpg(killer.pop("pid"), signal.SIGKILL)

    simulator.add(mcs.InProcessComponent(KillAt, "killer"))
    with simulator.start() as simulation:
        nodes = simulation.firmware.firmware_nodes
        assert nodes is not None
        assert nodes.pid is not None
        killer["pid"] = nodes.pid
        with pytest.raises(mcs.NodeCrashedError) as info:
            simulation.firmware.send(px4.Configuration([wp(40, 0, 15)], time_limit=120.0))
    assert info.value.name == "px4"
    assert info.value.exit_code == -signal.SIGKILL
    assert "Startup script returned successfully" in info.value.log_tail


def test_two_real_px4_fly_side_by_side(px4_sitl: RealPX4) -> None:
    config = px4.Configuration([wp(15, 10, 8)], end="land", time_limit=200.0)
    with (
        px4.PX4(fidelity="medium", firmware=px4_sitl.sitl(), seed=1).start() as one,
        px4.PX4(fidelity="medium", firmware=px4_sitl.sitl(), seed=2).start() as two,
    ):
        instances = {sim.firmware.instance for sim in (one, two)}
        results = [one.firmware.send(config), two.firmware.send(config)]
    assert len(instances) == 2
    for result in results:
        assert result.completed, result.reason


@pytest.mark.xdist_group("px4-usual-ports")  # both listen where PX4 SITL sends: 14540
@pytest.mark.parametrize("where", ["process", "container"])
def test_standalone_sitl_serves_px4s_usual_ports(
    px4_sitl: RealPX4, where: str, request: pytest.FixtureRequest
) -> None:
    command = [sys.executable, "-m", "multicosim", "px4", "sitl", "--speed", "5"]
    if where == "process":
        if px4_sitl.binary is None:
            pytest.skip("the standalone SITL runs a PX4 binary as a process")
        command += ["--px4-binary", px4_sitl.binary]
    else:
        request.getfixturevalue("mcs_runtime_image")  # an engine, and images up to date
        image = px4_sitl.image
        if image is None:
            from multicosim.px4.image import build_image

            assert px4_sitl.binary is not None
            image = build_image(px4.SITL(binary=px4_sitl.binary).bundle)
        command += ["--px4-image", image]
    proc = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        assert proc.stdout is not None
        match = None
        deadline = time.monotonic() + 60
        while match is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            assert line or proc.poll() is None, "the SITL exited before it was ready"
            match = re.search(r"instance (\d+) .*udpin://0.0.0.0:(\d+) .*logs: (\S+)\)", line)
        # (a container's PX4 is instance 0 of its own network, and sends to this host)
        assert match, "the SITL never said it was ready"
        instance, port, run_dir = int(match[1]), int(match[2]), match[3]
        assert port == API_PORT + instance
        gcs = mavutil.mavlink_connection(f"udpin:0.0.0.0:{port}", source_system=250)
        try:
            heartbeat = gcs.wait_heartbeat(timeout=60)
            assert heartbeat is not None
            assert heartbeat.autopilot == 12  # MAV_AUTOPILOT_PX4
            version = None
            for _ in range(10):
                gcs.mav.command_long_send(gcs.target_system, 1, 512, 0, 148, 0, 0, 0, 0, 0, 0)
                version = gcs.recv_match(type="AUTOPILOT_VERSION", blocking=True, timeout=3)
                if version is not None:
                    break
            assert version is not None
            v = version.flight_sw_version
            assert (v >> 24, v >> 16 & 0xFF, v >> 8 & 0xFF) == (1, 15, 4)
            # Paced at 5x, PX4 waits 5x as long (simulated) for a ground station's sticks.
            answer = None
            for _ in range(10):
                gcs.mav.param_request_read_send(gcs.target_system, 1, b"COM_RC_LOSS_T", -1)
                answer = gcs.recv_match(type="PARAM_VALUE", blocking=True, timeout=3)
                if answer is not None and answer.param_id == "COM_RC_LOSS_T":
                    break
            assert answer is not None
            assert answer.param_value == pytest.approx(2.5)
        finally:
            gcs.close()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(30) == 0
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)
        assert proc.stdout is not None
        proc.stdout.close()
    # PX4 is gone with it, and its run directory too.
    assert not Path(run_dir).exists()
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        with contextlib.suppress(OSError):
            assert run_dir.encode() not in cmdline.read_bytes(), f"{cmdline} outlived the SITL"


@pytest.mark.xdist_group("px4-usual-ports")  # listens where PX4 SITL sends: 14540 + N
def test_standalone_sitl_runs_a_fleet_of_real_px4(px4_sitl: RealPX4, sitl: Any) -> None:
    """``--count 2 --px4-binary``: two real PX4 instances in one world, each heard on its
    instance's usual port with its own MAV_SYS_ID, as PX4's multi-vehicle SITL has them."""
    if px4_sitl.binary is None:
        pytest.skip("the standalone SITL runs a PX4 binary as a process")
    args = ("--count", "2", "--speed", "4", "--px4-binary", px4_sitl.binary)
    with sitl(*args, timeout=180.0) as proc:
        seen = proc.ready.string  # its output up to the ready line
        found = re.findall(r"iris_\d: PX4 instance (\d+) \(MAV_SYS_ID (\d+)\)", seen)
        assert len(found) == 2, seen
        for instance, system_id in ((int(i), int(s)) for i, s in found):
            assert system_id == instance + 1
            link = mavutil.mavlink_connection(
                f"udpin:127.0.0.1:{API_PORT + instance}", source_system=250
            )
            try:
                heartbeat = link.wait_heartbeat(timeout=60)
            finally:
                link.close()
            assert heartbeat is not None
            assert (heartbeat.get_srcSystem(), heartbeat.autopilot) == (system_id, 12)
        run_dir = re.search(r"logs: (\S+)\)", seen)
        assert run_dir is not None
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(60) == 0
    assert not Path(run_dir[1]).exists(), "the fleet's run directory outlived it"


def test_paced_loss_timeouts_grow_with_the_speed_within_their_ranges() -> None:
    from multicosim.px4.autopilot.params import table
    from multicosim.px4.standalone import paced_params

    assert paced_params(1.0) == {}  # real time: PX4's own values
    assert paced_params(10.0) == {
        "COM_DL_LOSS_T": 100.0,
        "COM_RC_LOSS_T": 5.0,
        "COM_OF_LOSS_T": 5.0,
        "COM_OBC_LOSS_T": 50.0,
    }
    params = table()
    for speed in (0.1, 3.3, 1000.0):
        for name, value in paced_params(speed).items():
            low, high = params[name].min, params[name].max
            assert low is None or value >= low, name
            assert high is None or value <= high, name
    assert paced_params(3.3)["COM_DL_LOSS_T"] == 33.0  # an integer parameter stays one
