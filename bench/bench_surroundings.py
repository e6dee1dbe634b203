"""What obstacles and wind cost: a PX4 mission in an empty, calm world and in a busy, windy one.

The same 60 s mission (climb, two legs, land; ``bench_px4``'s) at low fidelity (point mass,
in-process) and at medium (MuJoCo world and autopilot as two processes), flown in the
fidelity's default world and in the same world with 10 obstacles off the path plus a steady
5 m/s wind with light turbulence (``physics.LIGHT``). Runs alternate between the two worlds
(same seed) so drifts in machine speed hit both; each starts after a full garbage
collection. The cost of a run is the CPU time of ``firmware.send(mission)``, in this
process and in its child processes (the medium world and autopilot), read from ``/proc``,
so other work on a shared machine does not count. The wind makes the flight longer, so
the cost is reported per simulated second (the target: at most +10 % at low, +5 % at
medium) and per run, each the median of the per-pair ratios.

Usage: ``python bench/bench_surroundings.py [--pairs N] [--quick]``. Prints a table and
writes ``bench/results/surroundings.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import os
import statistics
import time
from pathlib import Path
from typing import Any

from _common import write_result
from bench_px4 import mission

import multicosim.px4 as px4
from multicosim.physics import LIGHT, Box, Cylinder, Wind
from multicosim.px4.scenario import default_world

TARGET_PERCENT = {"low": 10.0, "medium": 5.0}
PAIRS = {"low": 30, "medium": 8}
QUICK_PAIRS = {"low": 6, "medium": 1}

# The mission flies home -> (30 N, 30 E) -> (85 N, 7 W): these stand 30 m or more beside it.
OBSTACLES = (
    *(
        Cylinder(north=n, east=-45.0, radius=2.0, height=20.0)
        for n in (0.0, 20.0, 40.0, 60.0, 80.0)
    ),
    *(
        Box(north=n, east=70.0, length=6.0, width=4.0, height=15.0, yaw=30.0)
        for n in (0.0, 20.0, 40.0, 60.0, 80.0)
    ),
)
WIND = Wind(speed=5.0, direction=270.0, turbulence=LIGHT)


def worlds(fidelity: str) -> dict[str, px4.WorldConfig]:
    """The fidelity's default world, and the same with obstacles and wind."""
    plain = default_world(fidelity)  # type: ignore[arg-type]
    return {"plain": plain, "busy": dataclasses.replace(plain, obstacles=OBSTACLES, wind=WIND)}


_TICKS = os.sysconf("SC_CLK_TCK")


def _children_cpu() -> dict[int, float]:
    """CPU seconds (user + system) of each process whose parent is this one (Linux)."""
    me, out = os.getpid(), {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            stat = Path(entry.path, "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[1]) == me:
            out[int(entry.name)] = (int(fields[11]) + int(fields[12])) / _TICKS
    return out


def fly(fidelity: str, world: px4.WorldConfig) -> tuple[float, float]:
    """(CPU s, simulated s) of one mission's ``send``, with its child processes."""
    gc.collect()
    with px4.PX4(world, fidelity=fidelity, seed=0).start() as simulation:  # type: ignore[arg-type]
        children = _children_cpu()
        cpu = time.process_time()
        result = simulation.firmware.send(mission())
        cpu = time.process_time() - cpu
        after = _children_cpu()
        cpu += sum(t - children.get(pid, 0.0) for pid, t in after.items())
    assert result.completed, result.reason
    return cpu, result.end_time


def measure(fidelity: str, pairs: int) -> dict[str, Any]:
    """Alternating pairs of runs in the two worlds: the cost ratios (see the module)."""
    kinds = worlds(fidelity)
    fly(fidelity, kinds["plain"])  # warm up: imports, caches
    runs: dict[str, list[tuple[float, float]]] = {"plain": [], "busy": []}
    for i in range(pairs):
        # Alternate which goes first, so neither always runs on a warmer machine.
        for name in ("plain", "busy") if i % 2 == 0 else ("busy", "plain"):
            runs[name].append(fly(fidelity, kinds[name]))
    per_run = [b[0] / a[0] for a, b in zip(runs["plain"], runs["busy"], strict=True)]
    per_second = [
        (b[0] / b[1]) / (a[0] / a[1]) for a, b in zip(runs["plain"], runs["busy"], strict=True)
    ]
    return {
        "pairs": pairs,
        "sim_s": {name: statistics.median(r[1] for r in rs) for name, rs in runs.items()},
        "cpu_s": {name: statistics.median(r[0] for r in rs) for name, rs in runs.items()},
        "per_second_percent": 100.0 * (statistics.median(per_second) - 1.0),
        "per_run_percent": 100.0 * (statistics.median(per_run) - 1.0),
        "per_second_ratios": per_second,
        "target_percent": TARGET_PERCENT[fidelity],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=None, help="pairs per fidelity")
    parser.add_argument("--quick", action="store_true", help="a few pairs")
    parser.add_argument("--only", choices=("low", "medium"), default=None)
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    levels = {}
    for fidelity in ("low", "medium"):
        if args.only and fidelity != args.only:
            continue
        pairs = args.pairs or (QUICK_PAIRS if args.quick else PAIRS)[fidelity]
        levels[fidelity] = r = measure(fidelity, pairs)
        print(
            f"{fidelity:<6} {r['sim_s']['plain']:5.1f} s / {r['sim_s']['busy']:5.1f} s simulated, "
            f"{r['cpu_s']['plain'] * 1e3:7.1f} / {r['cpu_s']['busy'] * 1e3:7.1f} ms CPU: "
            f"{r['per_second_percent']:+.1f} % per simulated s, {r['per_run_percent']:+.1f} % "
            f"per run (target <= +{r['target_percent']:g} %, median of {pairs} pairs)"
        )
    out = write_result(
        "surroundings",
        {
            "obstacles": len(OBSTACLES),
            "wind": {"speed": WIND.speed, "turbulence": WIND.turbulence},
            "levels": levels,
        },
        args.output,
    )
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
