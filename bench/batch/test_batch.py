"""A batch of simulation tests for ``bench/bench_throughput.py`` (``pytest -n 2`` vs ``-n 0``).

Not part of the test suite: run as ``pytest bench/batch --mcs-fidelity=medium``. Each test
flies a short rover mission in a fresh simulation, as a regression suite does.
``BENCH_BATCH_SIZE`` sets how many tests there are (default 8).
"""

from __future__ import annotations

import os

import pytest

import multicosim.rover as rover

MISSION = rover.Mission(speed=2.0, wait=1.0, distance=20.0, final_distance=20.0)


@pytest.mark.parametrize("seed", range(int(os.environ.get("BENCH_BATCH_SIZE", "8"))))
def test_mission_completes(seed: int, mcs_fidelity: rover.Fidelity) -> None:
    with rover.Rover(fidelity=mcs_fidelity, seed=seed).start() as simulation:
        assert simulation.controller.send(MISSION).completed
