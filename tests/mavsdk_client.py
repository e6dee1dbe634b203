"""MAVSDK as a ground station of one's own: it flies a short mission on whatever autopilot
answers on a UDP port (our built-in one or real PX4), as a user's MAVSDK script would.

Its waits are on the wall clock, as MAVSDK's own are: the simulations it flies are paced.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable, Sequence
from typing import Any, TypeVar

import pytest

from multicosim.core.geo import LocalProjection

__all__ = ["fly_mission"]

T = TypeVar("T")


async def _poll(
    get: Callable[[], Awaitable[T]], ok: Callable[[T], bool], timeout: float, what: str
) -> T:
    deadline = time.monotonic() + timeout
    while True:
        value = await get()
        if ok(value):
            return value
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}; last value {value!r}")
        await asyncio.sleep(0.1)


async def fly_mission(
    port: int,
    home: tuple[float, float],
    legs: Sequence[tuple[float, float]],
    alt: float = 10.0,
    timeout: float = 90.0,
) -> dict[str, Any]:
    """Fly ``legs`` (north, east in m from ``home``) at ``alt`` m with MAVSDK listening on
    UDP ``port``: wait for a healthy vehicle, upload, arm, start, wait for the last item.
    Returns what MAVSDK saw: the autopilot, its flight mode, progress, the end position and
    the last item's latitude and longitude."""
    from mavsdk.asyncio import Autopilot, ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission import MissionAsync, MissionItem, MissionPlan
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK saw no autopilot"
        autopilot = await system.autopilot_type()
        telemetry = TelemetryAsync(system)
        action = ActionAsync(system)
        mission = MissionAsync(system)
        await _poll(
            telemetry.health,
            lambda h: h.is_global_position_ok and h.is_home_position_ok and h.is_armable,
            60.0,
            "a healthy, armable vehicle",
        )
        proj = LocalProjection(*home)
        items = []
        for north, east in legs:
            lat, lon = proj.reproject(north, east)
            items.append(
                MissionItem(
                    latitude_deg=lat,
                    longitude_deg=lon,
                    relative_altitude_m=alt,
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
            timeout,
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
