"""Simulate functions for the campaign tests: importable by pool and Ray workers."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import multicosim.rover as rover
from multicosim.core.fidelity import check_fidelity

REQUIREMENT = "always (speed <= 4.5)"  # violated by the faster missions of the design
RANGES = {"speed": (1.0, 8.0), "distance": (2.0, 6.0)}


def simulate_rover(sample: dict[str, float], fidelity: str, seed: int) -> Any:
    """One low-fidelity rover mission per sample."""
    mission = rover.Mission(speed=sample["speed"], distance=sample["distance"], wait=0.5)
    with rover.Rover(fidelity=check_fidelity(fidelity), seed=seed).start() as simulation:
        return simulation.controller.send(mission)


def simulate_or_die(sample: dict[str, Any], fidelity: str, seed: int) -> Any:
    """As simulate_rover; the sample flagged ``victim`` first parks its worker for a kill.

    On its first attempt it writes its pid to ``victim`` and sleeps, so that the test can
    kill the worker mid-simulation; the retry finds the pid file and runs normally.
    """
    victim = sample.get("victim")
    if victim is not None and not Path(victim).exists():
        Path(victim).write_text(str(os.getpid()))
        time.sleep(60)
    return simulate_rover(sample, fidelity, seed)


def simulate_or_hang(sample: dict[str, Any], fidelity: str, seed: int) -> Any:
    """As simulate_rover; a sample flagged ``hang`` never returns."""
    if sample.get("hang"):
        time.sleep(3600)
    return simulate_rover(sample, fidelity, seed)


def worker_pid() -> int:
    """The pid of the process running this call."""
    return os.getpid()


def simulate_slowly(sample: dict[str, Any], fidelity: str, seed: int) -> Any:
    """As simulate_rover, recording the worker's pid; samples flagged ``slow`` take a minute."""
    Path(sample["pids"], str(os.getpid())).touch()
    if sample.get("slow"):
        time.sleep(60)
    return simulate_rover(sample, fidelity, seed)
