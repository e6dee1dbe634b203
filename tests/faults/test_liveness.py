"""Simulated time decides: real PX4 and ArduCopter missions on a machine oversubscribed by
twice as many busy processes as it has cores pass with a ground-station timeout of 2 s, far
below their wall time (tens of seconds), because the timeout is liveness (the longest the
simulated clock may stand still), not a bound on the mission.
"""

from __future__ import annotations

import os

import multicosim.ardupilot as ardupilot
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.local import CpuLoad
from pytest_multicosim.px4 import RealPX4

SEND_TIMEOUT = 2.0  # wall seconds the clock may stand still: far below a mission's wall time


def oversubscribed() -> CpuLoad:
    """Twice as many busy processes as the machine has cores, stopped on the way out."""
    return CpuLoad(2 * (os.cpu_count() or 1))


def mission(home: px4.Home) -> px4.Configuration:
    """Take off to 12 m, 40 m north, 20 m east, land: about 40 simulated seconds."""
    proj = LocalProjection(home.lat, home.lon)
    wps = [proj.reproject(40.0, 0.0), proj.reproject(40.0, 20.0)]
    return px4.Configuration([px4.Waypoint(lat, lon, 12.0) for lat, lon in wps])


def test_real_px4_flies_a_mission_on_an_oversubscribed_machine(px4_sitl: RealPX4) -> None:
    simulator = px4.PX4(fidelity="medium", firmware=px4_sitl.sitl())
    with simulator.start() as simulation, oversubscribed():
        result = simulation.firmware.send(mission(px4.Home()), timeout=SEND_TIMEOUT)
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0, 1]


def test_arducopter_flies_a_mission_on_an_oversubscribed_machine(ardupilot_dir: str) -> None:
    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir)
    with simulator.start() as simulation, oversubscribed():
        result = simulation.firmware.send(mission(simulation.home), timeout=SEND_TIMEOUT)
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0, 1]
