"""MAVSDK (the SDK that drives real PX4) flies a mission on our autopilot over UDP.

The autopilot runs as ``python -m multicosim px4 sitl`` in its own process, paced at a
multiple of real time, and sends to the port MAVSDK listens on, as PX4 SITL sends to 14540.
Nothing is mocked: MAVSDK's C++ core speaks MAVLink over loopback sockets.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

import pytest

from multicosim.core.geo import LocalProjection

mavsdk = pytest.importorskip("mavsdk.asyncio", reason="mavsdk (pip install mavsdk) not installed")

HOME = (47.397742, 8.545594)
SPEED = 4.0  # simulated seconds per wall second


async def _poll(get, ok, timeout: float, what: str):  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while True:
        value = await get()
        if ok(value):
            return value
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}; last value {value!r}")
        await asyncio.sleep(0.1)


async def _fly(port: int) -> dict[str, Any]:
    from mavsdk.asyncio import Autopilot, ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission import MissionAsync, MissionItem, MissionPlan
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=15.0)
        assert system is not None, "MAVSDK saw no autopilot"
        autopilot = await system.autopilot_type()
        telemetry = TelemetryAsync(system)
        action = ActionAsync(system)
        mission = MissionAsync(system)
        await _poll(
            telemetry.health,
            lambda h: h.is_global_position_ok and h.is_home_position_ok and h.is_armable,
            30.0,
            "a healthy, armable vehicle",
        )
        proj = LocalProjection(*HOME)
        items = []
        for north, east in ((30.0, 0.0), (30.0, 25.0)):
            lat, lon = proj.reproject(north, east)
            items.append(
                MissionItem(
                    latitude_deg=lat,
                    longitude_deg=lon,
                    relative_altitude_m=10.0,
                    speed_m_s=5.0,
                    is_fly_through=True,
                    acceptance_radius_m=2.0,
                )
            )
        await mission.upload_mission(MissionPlan(items))
        await action.arm()
        await mission.start_mission()
        flight_mode = await _poll(
            telemetry.flight_mode, lambda m: m.name == "MISSION", 10.0, "mission mode"
        )
        progress = await _poll(
            mission.mission_progress,
            lambda p: p.current == p.total,
            90.0,
            "the mission to finish",
        )
        finished = await mission.is_mission_finished()
        position = await telemetry.position()
        return {
            "autopilot": autopilot,
            "expected_autopilot": Autopilot.PX4,
            "flight_mode": flight_mode,
            "progress": (progress.current, progress.total),
            "finished": finished,
            "position": position,
            "last": (items[-1].latitude_deg, items[-1].longitude_deg),
        }


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_mavsdk_flies_a_mission_on_our_autopilot(udp_port: int, sitl: Any, fidelity: str) -> None:
    port = udp_port
    with sitl(
        "--fidelity", fidelity, "--speed", str(SPEED), "--gcs-port", "0", "--api-port", str(port)
    ):
        out = asyncio.run(_fly(port))
    assert out["autopilot"] == out["expected_autopilot"]
    assert out["progress"] == (2, 2)
    assert out["finished"] is True
    pos = out["position"]
    lat, lon = out["last"]
    north, east = LocalProjection(lat, lon).project(pos.latitude_deg, pos.longitude_deg)
    assert (north**2 + east**2) ** 0.5 < 5.0, "the vehicle is not at the last waypoint"
    assert abs(pos.relative_altitude_m - 10.0) < 2.0
