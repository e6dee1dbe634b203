"""The real-PX4 path: PX4's simulator interface (TCP 4560, lockstep) and the launch.

The bridge is checked against a MAVLink peer that behaves like PX4's simulator_mavlink
(TCP client; answers each sensor step with HIL_ACTUATOR_CONTROLS). Flying a real PX4 needs a
PX4 SITL binary or image, which our machines cannot obtain: that test skips with the reason.
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Any

import pytest

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.px4._geo import LocalProjection
from multicosim.px4._hil import Truth
from multicosim.px4._real import HilTcpBridge, RealPX4Component
from multicosim.px4._simulator import WorldComponent

mavutil = pytest.importorskip("pymavlink.mavutil")


class FakeSimulatorClient(threading.Thread):
    """Connects like PX4 SITL and answers every IMU sample with fixed motor outputs."""

    def __init__(self, port: int, throttle: float) -> None:
        super().__init__(name="px4-like", daemon=True)
        self.port, self.throttle = port, throttle
        self.stop = threading.Event()
        self.imu = 0
        self.gps_fix = 0
        self.error: BaseException | None = None

    def run(self) -> None:
        try:
            from pymavlink.dialects.v20 import common

            mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
            with socket.create_connection(("127.0.0.1", self.port), timeout=5) as sock:
                sock.settimeout(0.2)
                while not self.stop.is_set():
                    try:
                        data = sock.recv(65536)
                    except TimeoutError:
                        continue
                    if not data:
                        return
                    for m in mav.parse_buffer(data) or ():
                        if m.get_type() == "HIL_GPS":
                            self.gps_fix = m.fix_type
                        if m.get_type() == "HIL_SENSOR" and m.fields_updated & 0x3F == 0x3F:
                            self.imu += 1
                            controls = [self.throttle] * 4 + [0.0] * 12
                            out = mav.hil_actuator_controls_encode(m.time_usec, controls, 128, 1)
                            sock.sendall(out.pack(mav))
        except BaseException as exc:
            self.error = exc


@pytest.mark.parametrize("process", [False, True], ids=["native", "mavlink"])
def test_bridge_runs_the_world_in_lockstep_with_a_tcp_simulator_client(process: bool) -> None:
    world = px4.MuJoCo()
    sim = mcs.ProcessSimulator(seed=0)
    sim.add(WorldComponent(world, "medium", process=process))
    wire = "mavlink" if process else "native"
    bridge_id = sim.add(
        mcs.ParticipantComponent(
            lambda: HilTcpBridge(world.topics, period=world.period, port=0, wire=wire), "hil"
        )
    )
    truth: list[Truth] = []

    class Recorder:
        period = 0.05

        def setup(self, ctx: Any) -> None:
            self.sub = ctx.subscribe(world.topics.truth, Truth)

        def step(self, ctx: Any) -> None:
            truth.extend(self.sub.messages)

    sim.add(mcs.ParticipantComponent(Recorder, "recorder"))
    with sim.start() as simulation:
        bridge: HilTcpBridge = simulation.get(bridge_id).participant  # type: ignore[attr-defined]
        client = FakeSimulatorClient(bridge.port, throttle=0.6)
        client.start()
        deadline = time.monotonic() + 10
        while not bridge.connected and time.monotonic() < deadline:
            simulation.advance(world.period)
        assert bridge.connected
        simulation.advance(2.0)
        client.stop.set()
        client.join(5)
    assert client.error is None, client.error
    assert bridge.steps == bridge.replies > 200  # every step answered: lockstep
    assert client.imu >= bridge.steps
    assert client.gps_fix == 3
    assert truth[-1].alt > 1.0, "60 % throttle did not lift the quadrotor"
    lat, lon = truth[-1].lat, truth[-1].lon
    n, e = LocalProjection(world.home.lat, world.home.lon).project(lat, lon)
    assert abs(n) < 1.0
    assert abs(e) < 1.0


def test_component_needs_exactly_one_source() -> None:
    with pytest.raises(mcs.ConfigurationError):
        RealPX4Component()
    with pytest.raises(mcs.ConfigurationError):
        RealPX4Component(binary="px4", image="img")
    cmd = RealPX4Component(image="multicosim/px4-sitl:v1.15.4").command()
    assert cmd[:2] == ["docker", "run"]
    assert "--network" in cmd


def test_real_px4_flies_a_mission(px4_real: Any) -> None:
    from multicosim.px4._real import real_px4_simulator

    sim, node_id = real_px4_simulator(binary=px4_real.binary, image=px4_real.image)
    lat, lon = LocalProjection(47.397742, 8.545594).reproject(30.0, 0.0)
    with sim.start() as simulation:
        result = simulation.get(node_id).send(
            px4.Configuration([px4.Waypoint(lat, lon, 10.0)], time_limit=300.0)
        )
    assert result.completed, result.reason
