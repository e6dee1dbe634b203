"""Falsification throughput: simulations per minute at each fidelity, and pytest-xdist scaling.

1. Simulations per minute: the 60 s rover mission of ``bench_rover.py`` in a fresh
   simulation per example (start, send, stop: what a falsifying search pays per example),
   at low, medium and high fidelity (high on Docker where an engine runs).
2. ``pytest -n 2`` against ``-n 0``: the same batch of medium-fidelity simulation tests
   (``bench/batch``), wall time of the whole pytest run, side by side; the speedup on the
   machine's cores.

Usage: ``python bench/bench_throughput.py [--quick]``; prints a table and writes
``bench/results/throughput.json``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import HERE, ROOT, python_env, write_result
from bench_rover import MISSION, high_placement

import multicosim.rover as rover


def simulations_per_minute(fidelity: str, n: int, placement: str | None = None) -> dict[str, Any]:
    """Run ``n`` fresh missions back to back; simulations per minute of wall time."""
    walls = []
    for seed in range(n):
        t0 = time.perf_counter()
        with rover.Rover(fidelity=fidelity, placement=placement, seed=seed).start() as sim:  # type: ignore[arg-type]
            trajectory = sim.controller.send(MISSION)
        walls.append(time.perf_counter() - t0)
        assert trajectory.completed, trajectory.reason
    total = sum(walls)
    return {
        "placement": placement or ("in-process" if fidelity == "low" else "process"),
        "simulations": n,
        "wall_s": total,
        "per_simulation_s": total / n,
        "per_minute": 60.0 * n / total,
    }


def pytest_batch(workers: int, size: int, fidelity: str) -> dict[str, Any]:
    """Wall time of ``pytest -n WORKERS`` over the batch (one pytest process per run)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [
            sys.executable,
            "-m",
            "pytest",
            str(HERE / "batch"),
            f"-n{workers}",
            f"--mcs-fidelity={fidelity}",
            f"--mcs-artifacts={tmp}",
            "-q",
            "-p",
            "no:cacheprovider",
        ]
        env = {**os.environ, **python_env(), "BENCH_BATCH_SIZE": str(size)}
        t0 = time.perf_counter()
        done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"pytest -n {workers} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    return {"workers": workers, "tests": size, "wall_s": wall, "tests_per_minute": 60 * size / wall}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer simulations, smaller batch")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    counts = (
        {"low": 10, "medium": 2, "high": 1} if args.quick else {"low": 30, "medium": 4, "high": 2}
    )
    batch = 4 if args.quick else 8

    placement, fallback = high_placement()
    levels = {
        "low": simulations_per_minute("low", counts["low"]),
        "medium": simulations_per_minute("medium", counts["medium"]),
        "high": simulations_per_minute("high", counts["high"], placement),
    }
    levels["high"]["fallback_reason"] = fallback
    serial = pytest_batch(0, batch, "medium")
    parallel = pytest_batch(2, batch, "medium")
    report = {
        "mission": "rover 60 s (bench_rover.MISSION), fresh simulation per example",
        "levels": levels,
        "pytest": {
            "fidelity": "medium",
            "n0": serial,
            "n2": parallel,
            "speedup": serial["wall_s"] / parallel["wall_s"],
            "cores": os.cpu_count(),
        },
    }
    print(f"{'level':<10}{'placement':>11}{'sims':>6}{'s/sim':>8}{'sims/min':>10}")
    for level, r in levels.items():
        print(
            f"{level:<10}{r['placement']:>11}{r['simulations']:>6}{r['per_simulation_s']:>8.2f}"
            f"{r['per_minute']:>10.0f}"
        )
    print(
        f"pytest batch of {batch} medium tests: -n 0 {serial['wall_s']:.1f} s, "
        f"-n 2 {parallel['wall_s']:.1f} s, speedup {report['pytest']['speedup']:.2f}"
    )
    out = write_result("throughput", report, args.output)
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
