"""MAVSDK (the SDK that drives real PX4) flies a mission on our autopilot over UDP.

The autopilot runs as ``python -m multicosim px4 sitl`` in its own process, paced at a
multiple of real time, and sends to the port MAVSDK listens on, as PX4 SITL sends to 14540.
Nothing is mocked: MAVSDK's C++ core speaks MAVLink over loopback sockets.
"""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from mavsdk_client import fly_mission

from multicosim.core.geo import LocalProjection

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
