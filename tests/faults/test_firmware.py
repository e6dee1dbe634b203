"""Real firmware failing mid-flight at medium fidelity: PX4 and ArduPilot SITL killed, PX4
frozen. Each is reported naming the autopilot and the fault, and the next flight starts.
"""

from __future__ import annotations

import dataclasses
import os
import signal
from typing import Any

import pytest
from fault_helpers import Detections, Trigger, airborne, failing

import multicosim as mcs
import multicosim.ardupilot as ardupilot
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.hil import Truth
from pytest_multicosim.px4 import RealPX4

HEIGHT = 5.0  # m above home: the vehicle is flying
LOCKSTEP_TIMEOUT = 3.0  # s: how long PX4 may leave a lockstep step unanswered here
CRASH = 0.0  # a crash has no timeout of its own: the bridges see it at once


def flight(home: px4.Home) -> px4.Configuration:
    """Take off to 12 m, fly 30 m north (a mission PX4 and ArduPilot fly alike)."""
    lat, lon = LocalProjection(home.lat, home.lon).reproject(30.0, 0.0)
    return px4.Configuration([px4.Waypoint(lat, lon, 12.0)], time_limit=200.0)


def signal_when_airborne(
    simulator: Any, name: str, topic: str, sig: signal.Signals
) -> tuple[Trigger, dict[str, int]]:
    """A trigger, added to ``simulator``, that sends ``sig`` to process ``name`` in flight.

    Put the process's pid in the returned dict once the simulation has started.
    """
    pids: dict[str, int] = {}
    trigger = Trigger(
        airborne(HEIGHT), lambda: os.killpg(pids[name], sig), topic=topic, type=Truth, period=0.02
    )
    simulator.add(mcs.InProcessComponent(lambda: trigger, name="fault"))
    return trigger, pids


def pid_of(simulation: Any, name: str) -> int:
    """The process id of firmware process ``name`` in a scenario simulation."""
    return int(simulation.simulation.environment.processes[name].pid)


def next_px4_flies(sitl: px4.SITL) -> None:
    """A new real PX4 starts, connects to its simulator and runs in lockstep."""
    with px4.PX4(fidelity="medium", firmware=sitl).start() as simulation:
        start = simulation.time
        simulation.advance(2.0)
        assert simulation.time == pytest.approx(start + 2.0)


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGSTOP], ids=["killed", "frozen"])
def test_real_px4_fails_mid_flight(
    px4_sitl: RealPX4, detections: Detections, sig: signal.Signals
) -> None:
    sitl = dataclasses.replace(px4_sitl.sitl(), lockstep_timeout=LOCKSTEP_TIMEOUT)
    simulator = px4.PX4(fidelity="medium", firmware=sitl)
    trigger, pids = signal_when_airborne(simulator, "px4", "px4/truth", sig)
    expected: type[mcs.NodeError] = (
        mcs.NodeCrashedError if sig == signal.SIGKILL else mcs.NodeTimeoutError
    )
    with simulator.start() as simulation:
        pids["px4"] = pid_of(simulation, "px4")
        error, error_at = failing(
            lambda: simulation.firmware.send(flight(simulation.home)), expected
        )
    assert trigger.fault_at is not None
    assert error.name == "px4"
    assert "Startup script returned successfully" in error.log_tail
    if sig == signal.SIGKILL:
        assert error.exit_code == -signal.SIGKILL
        assert "'px4' crashed (killed by SIGKILL) at simulated step" in str(error)
        fault, timeout = "real PX4 killed mid-flight", CRASH
    else:
        assert (
            f"'px4' sent no HIL_ACTUATOR_CONTROLS within {LOCKSTEP_TIMEOUT:g} s of wall time"
            in str(error)
        )
        assert "it is frozen (its process is stopped, as by SIGSTOP)" in str(error)
        fault, timeout = "real PX4 frozen mid-flight (SIGSTOP)", LOCKSTEP_TIMEOUT
    detections.record(fault, trigger.fault_at, error_at, timeout, error)
    next_px4_flies(sitl)


def test_real_ardupilot_killed_mid_flight(ardupilot_dir: str, detections: Detections) -> None:
    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir)
    trigger, pids = signal_when_airborne(simulator, "ardupilot", "ardupilot/truth", signal.SIGKILL)
    with simulator.start() as simulation:
        pids["ardupilot"] = pid_of(simulation, "ardupilot")
        error, error_at = failing(
            lambda: simulation.firmware.send(flight(simulation.home)), mcs.NodeCrashedError
        )
    assert trigger.fault_at is not None
    assert (error.name, error.exit_code) == ("ardupilot", -signal.SIGKILL)
    assert "'ardupilot' crashed (killed by SIGKILL) at physics frame" in str(error)
    assert "Starting sketch 'ArduCopter'" in error.log_tail
    detections.record("real ArduPilot killed mid-flight", trigger.fault_at, error_at, CRASH, error)
    # The next ArduPilot starts (its first servo packet) and steps in lockstep.
    with ardupilot.ArduCopter(fidelity="medium", firmware_dir=ardupilot_dir).start() as simulation:
        start = simulation.time  # its start waited for ArduPilot's first servo packet
        simulation.advance(2.0)
        assert simulation.time == pytest.approx(start + 2.0)
