"""The public surface of ``multicosim.ardupilot``: its names, and PX4's mission types."""

from __future__ import annotations

import subprocess
import sys

import multicosim.ardupilot as ardupilot
import multicosim.px4 as px4

EXPECTED = {
    "FIRMWARE_FIDELITIES",
    "SITL",
    "ArduPilotComponent",
    "ArduPilotNode",
    "ArduPilotSimulation",
    "Configuration",
    "ArduCopter",
    "Fidelity",
    "Geofence",
    "Home",
    "MissionResult",
    "ArduRover",
    "FlightSample",
    "Waypoint",
    "WaypointReached",
    "WorldConfig",
    "boot",
    "default_world",
    "frame_period",
    "read_params",
}


def test_exported_names_are_the_intended_ones() -> None:
    assert set(ardupilot.__all__) == EXPECTED
    for name in ardupilot.__all__:
        assert getattr(ardupilot, name) is not None, name


def test_missions_are_px4s_types() -> None:
    # One mission, flown by either autopilot.
    assert ardupilot.Configuration is px4.Configuration
    assert ardupilot.Waypoint is px4.Waypoint
    assert ardupilot.MissionResult is px4.MissionResult


def test_import_stays_light() -> None:
    code = (
        "import sys, multicosim.ardupilot as a; a.Configuration; "
        "print([m for m in ('docker', 'mujoco', 'pymavlink') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_firmware_levels_are_a_subset_of_the_ladder() -> None:
    import multicosim as mcs

    assert ardupilot.FIRMWARE_FIDELITIES == ("medium", "high")
    assert set(ardupilot.FIRMWARE_FIDELITIES) < set(mcs.FIDELITIES)
    assert not hasattr(ardupilot, "FIDELITIES")  # its former name, removed with 0.2
