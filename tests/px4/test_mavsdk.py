"""MAVSDK (the SDK that drives real PX4) flies a mission on our autopilot over UDP.

The autopilot runs as ``python -m multicosim px4 sitl`` in its own process, paced at a
multiple of real time, and sends to the port MAVSDK listens on, as PX4 SITL sends to 14540.
Nothing is mocked: MAVSDK's C++ core speaks MAVLink over loopback sockets.
"""

from __future__ import annotations

import asyncio
import math
import re
from typing import Any

import pytest
from mavsdk_client import fly_mission

from multicosim.core.geo import LocalProjection
from multicosim.mavlink.udp import API_PORT

mavsdk = pytest.importorskip("mavsdk.asyncio", reason="mavsdk (pip install mavsdk) not installed")

HOME = (47.397742, 8.545594)
SPEED = 4.0  # simulated seconds per wall second


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_mavsdk_flies_a_mission_on_our_autopilot(udp_port: int, sitl: Any, fidelity: str) -> None:
    port = udp_port
    with sitl(
        "--fidelity", fidelity, "--speed", str(SPEED), "--gcs-port", "0", "--api-port", str(port)
    ):
        out = asyncio.run(fly_mission(port, HOME, [(30.0, 0.0), (30.0, 25.0)]))
    assert out["autopilot"] == out["expected_autopilot"]
    assert out["progress"] == (2, 2)
    assert out["finished"] is True
    pos = out["position"]
    lat, lon = out["last"]
    north, east = LocalProjection(lat, lon).project(pos.latitude_deg, pos.longitude_deg)
    assert (north**2 + east**2) ** 0.5 < 5.0, "the vehicle is not at the last waypoint"
    assert abs(pos.relative_altitude_m - 10.0) < 2.0


@pytest.mark.xdist_group("px4-usual-ports")  # listens where PX4 SITL sends: 14540 + N
def test_mavsdk_flies_the_second_vehicle_of_a_fleet_on_its_instances_port(sitl: Any) -> None:
    """``--count 2``: each vehicle on PX4's ports for its instance; MAVSDK flies the second
    one, found where PX4's multi-vehicle SITL puts instance 1, while the first is heard apart."""
    from pymavlink import mavutil

    with sitl("--count", "2", "--fidelity", "low", "--speed", str(SPEED)) as proc:
        seen = proc.ready.string  # its output up to the ready line
        ports = {
            int(m[1]): (int(m[2]), int(m[3]))
            for m in re.finditer(r"iris_(\d): PX4 instance (\d+) \(MAV_SYS_ID (\d+)\)", seen)
        }
        assert sorted(ports) == [0, 1], seen
        (first, first_id), (second, second_id) = ports[0], ports[1]
        assert (second_id, first_id) == (second + 1, first + 1)
        link = mavutil.mavlink_connection(f"udpin:127.0.0.1:{API_PORT + first}", source_system=250)
        try:
            heartbeat = link.wait_heartbeat(timeout=30)
        finally:
            link.close()
        assert heartbeat is not None
        assert heartbeat.get_srcSystem() == first_id
        out = asyncio.run(fly_mission(API_PORT + second, HOME, [(30.0, 0.0)]))
    assert out["autopilot"] == out["expected_autopilot"]
    assert out["progress"] == (1, 1)
    pos = out["position"]
    north, east = LocalProjection(*HOME).project(pos.latitude_deg, pos.longitude_deg)
    # (legs are from the first vehicle's start, the world's origin; the second starts 3 m north)
    assert math.dist((north, east), (30.0, 0.0)) < 5.0, "the vehicle is not at its waypoint"
