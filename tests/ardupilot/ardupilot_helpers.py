"""Helpers of the ArduPilot tests: stand-in SITL directories and waypoints around home."""

from __future__ import annotations

import sys
from pathlib import Path

import multicosim.ardupilot as ardupilot

STANDIN = Path(__file__).with_name("standin.py")


def fake_ardupilot(directory: Path, behaviour: str = "climb") -> Path:
    """An ArduPilot SITL directory whose binaries are the stand-in with ``behaviour``."""
    (directory / "bin").mkdir(parents=True)
    (directory / "params").mkdir()
    for name in ("arducopter", "ardurover"):
        binary = directory / "bin" / name
        binary.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{STANDIN}" {behaviour} "$@"\n')
        binary.chmod(0o755)
    for name in ("copter.parm", "rover.parm"):
        (directory / "params" / name).write_text("FRAME_CLASS 1\n")
    return directory


def wp(home: ardupilot.Home, north: float, east: float, alt: float) -> ardupilot.Waypoint:
    """A waypoint ``north``/``east`` metres from ``home``, ``alt`` metres above it."""
    return ardupilot.Waypoint.local(north, east, alt, home)
