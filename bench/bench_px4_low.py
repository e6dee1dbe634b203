"""Low-fidelity PX4 speed on a 4-waypoint mission, from ``send`` to the result.

The built-in autopilot and its ground station run in one process at low fidelity; they
talk MAVLink over the uplink/downlink topics. Two ways, side by side in one run, each the
best of ``--repeat`` alternating runs:

1. ``messages``: the autopilot's downlink carries packed frames and, in-process, the
   ground station takes the messages they were packed from (``_mav.remember``);
2. ``frames``: the ground station parses every frame (what a peer in another process,
   or behind a socket, does).

Speed factor = simulated seconds / wall seconds of ``firmware.send(mission)``, as a user
times it (target >= 1000x). Usage: ``python bench/bench_px4_low.py [--repeat N]``; prints a
table and writes ``bench/results/px4_low.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from _common import write_result

import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink import dialect as _mav

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
TARGET = 1000.0


def mission() -> px4.Configuration:
    """Four waypoints on a 60 m square at 20 m, then land."""
    wps = []
    for north, east in ((60.0, 0.0), (60.0, 60.0), (0.0, 60.0), (0.0, 0.0)):
        lat, lon = PROJ.reproject(north, east)
        wps.append(px4.Waypoint(lat, lon, 20.0))
    return px4.Configuration(wps, end="land", time_limit=300.0)


def fly() -> tuple[float, float]:
    """(simulated s, wall s of send) of one mission at low fidelity."""
    with px4.PX4(fidelity="low", seed=0).start() as simulation:
        t0 = time.perf_counter()
        result = simulation.firmware.send(mission())
        wall = time.perf_counter() - t0
    assert result.completed, result.reason
    return result.end_time, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="two repeats")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.quick:
        args.repeat = 2
    remember = _mav.remember
    ways: dict[str, Any] = {"messages": remember, "frames": lambda data, frames: None}
    best: dict[str, tuple[float, float]] = {}
    fly()  # warm up: imports, the parameter table, MuJoCo-free but not free
    for _ in range(args.repeat):
        for name, fn in ways.items():
            _mav.remember = fn
            try:
                sim, wall = fly()
            finally:
                _mav.remember = remember
            if name not in best or wall < best[name][1]:
                best[name] = (sim, wall)
    rows = {
        name: {"sim_s": sim, "send_s": wall, "speed_factor": sim / wall}
        for name, (sim, wall) in best.items()
    }
    for name, row in rows.items():
        print(
            f"{name:10s} {row['sim_s']:6.1f} s simulated in {row['send_s'] * 1e3:6.1f} ms: "
            f"{row['speed_factor']:6.0f}x (target {TARGET:g}x)"
        )
    write_result("px4_low", {"target": TARGET, "ways": rows}, args.output)


if __name__ == "__main__":
    main()
