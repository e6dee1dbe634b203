"""ArduCopter flies a QGroundControl plan, with its fence, rally points and a parameter file.

Needs ArduPilot's SITL directory (``--mcs-ardupilot-dir`` or ``MCS_ARDUPILOT_DIR``).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import multicosim.ardupilot as ardupilot
from multicosim.core.geo import LocalProjection

pytestmark = pytest.mark.usefixtures("no_leaks")

DATA = Path(__file__).parent.parent / "data"
PLAN = DATA / "survey_site.plan"


def test_arducopter_flies_a_qgc_plan(ardupilot_dir: str) -> None:
    config = ardupilot.Configuration.from_plan(PLAN)
    params = ardupilot.read_params(DATA / "slow_climb_copter.csv")
    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir, params=params)
    with simulator.start() as simulation:
        home = simulation.home
        result = simulation.firmware.send(config)
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0, 1, 2]  # no item reached for the landing
    times = [r.time for r in result.reached]
    assert times[2] - times[1] >= 5.0  # the loiter's 5 s at least
    # ArduPilot's own account of the items it flew (each said more than once), the camera
    # command among them.
    flown = dict.fromkeys(m for m in result.messages if m.startswith("Mission: "))
    assert list(flown) == [
        "Mission: 1 Takeoff",
        "Mission: 2 WP",
        "Mission: 3 ChangeSpeed",
        "Mission: 4 WP",
        "Mission: 5 ImageStartCapture",
        "Mission: 6 LoitTime",
        "Mission: 7 Land",
    ]
    assert result.landed
    assert not result.armed
    projection = LocalProjection(home.lat, home.lon)
    land_at = projection.project(47.397742, 8.545994)
    last = result.trajectory[-1]
    n, e = projection.project(last.true_lat, last.true_lon)
    assert math.hypot(n - land_at[0], e - land_at[1]) < 3.0
    # The parameter file's 1 m/s climb (ArduCopter's default is 2.5 m/s).
    assert max(-s.vz for s in result.trajectory if s.alt < 13.0) < 1.3
