"""A fleet's cost against its number of vehicles, and one vehicle with and without the fleet.

1. Built-in autopilots, 1 to 32 at low fidelity (each a point-mass world and an autopilot in
   this process) and 1 to 8 at medium (one MuJoCo world holding them all, each autopilot a
   process): every vehicle flies the same 30 m leg at once, side by side in lanes 6 m apart.
   Wall time of ``fly`` per simulated second, its growth exponent against the number of
   vehicles (1 is linear), and the cost per vehicle.
2. Real PX4, 1 to 4 instances in one world at medium (with ``--px4-binary`` or
   ``MCS_PX4_BINARY``): the real-time factor of each.
3. One vehicle: ``px4.PX4`` against a fleet of one, the same mission at low and medium,
   rounds interleaved (best of ``--repeat``): the fleet's own cost for a single vehicle.

Usage: ``python bench/bench_fleet.py [--quick] [--repeat N]``; prints a table and writes
``bench/results/fleet.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

from _common import fit_exponent, fit_linear, write_result

from multicosim import fleet, px4
from multicosim.physics import Pose

LOW = (1, 2, 4, 8, 16, 32)
MEDIUM = (1, 2, 4, 8)
REAL = (1, 2, 3, 4)
LANE = 6.0  # m between two vehicles' legs, east-west
LEG = 30.0  # m north
ALT = 10.0


def leg(east: float) -> px4.Configuration:
    """Take off, fly ``LEG`` m north along ``east``, land."""
    return px4.Configuration([px4.Waypoint.local(LEG, east, ALT)], end="land", time_limit=300.0)


def flown(count: int, fidelity: str, firmware: px4.SITL | None = None) -> dict[str, Any]:
    """``count`` vehicles fly their legs at once: wall time of ``fly`` and simulated time."""
    names = [f"v{i}" for i in range(count)]
    simulator = fleet.Fleet(
        {
            name: fleet.PX4Vehicle(start=Pose(east=LANE * i), firmware=firmware)
            for i, name in enumerate(names)
        },
        fidelity=fidelity,  # type: ignore[arg-type]
        seed=0,
    )
    with simulator.start() as simulation:
        start = simulation.time
        t0 = time.perf_counter()
        result = simulation.fly({name: leg(LANE * i) for i, name in enumerate(names)})
        wall = time.perf_counter() - t0
        sim = simulation.time - start
    for name, r in result.results.items():
        assert r.completed, (name, r.reason)
    return {"vehicles": count, "wall_s": wall, "sim_s": sim, "speed_factor": sim / wall}


def growth(fidelity: str, counts: tuple[int, ...], repeat: int) -> dict[str, Any]:
    """Best-of-``repeat`` cost per simulated second for each count, rounds interleaved."""
    best: dict[int, dict[str, Any]] = {}
    for _ in range(repeat):
        for n in counts:
            r = flown(n, fidelity)
            r["per_sim_s"] = r["wall_s"] / r["sim_s"]
            if n not in best or r["per_sim_s"] < best[n]["per_sim_s"]:
                best[n] = r
    points = [best[n] for n in counts]
    ns = [float(n) for n in counts]
    costs = [p["per_sim_s"] for p in points]
    return {
        "points": points,
        "exponent": fit_exponent(ns, costs),
        # The slope of a straight line through every point: wall s per simulated s per vehicle.
        "per_vehicle": fit_linear(ns, costs)[1],
    }


def one_vehicle(fidelity: str, repeat: int) -> dict[str, Any]:
    """``px4.PX4`` and a fleet of one, the same leg, interleaved: best wall per simulated s."""
    best = {"px4.PX4": float("inf"), "fleet of one": float("inf")}
    for _ in range(repeat):
        simulator = px4.PX4(fidelity=fidelity, seed=0)  # type: ignore[arg-type]
        with simulator.start() as simulation:
            t0 = time.perf_counter()
            result = simulation.firmware.send(leg(0.0))
            wall = time.perf_counter() - t0
        assert result.completed, result.reason
        best["px4.PX4"] = min(best["px4.PX4"], wall / result.duration)
        r = flown(1, fidelity)
        best["fleet of one"] = min(best["fleet of one"], r["wall_s"] / r["sim_s"])
    return {"per_sim_s": best, "ratio": best["fleet of one"] / best["px4.PX4"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer vehicles, one round")
    parser.add_argument("--repeat", type=int, default=2, help="rounds (best of)")
    parser.add_argument("--px4-binary", default=os.environ.get("MCS_PX4_BINARY"))
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    low = LOW[:4] if args.quick else LOW
    medium = MEDIUM[:2] if args.quick else MEDIUM
    report: dict[str, Any] = {
        "leg_m": LEG,
        "growth": {"low": growth("low", low, repeat), "medium": growth("medium", medium, 1)},
        "one_vehicle": {level: one_vehicle(level, repeat) for level in ("low", "medium")},
    }
    if args.px4_binary:
        sitl = px4.SITL(binary=args.px4_binary)
        real = REAL[:2] if args.quick else REAL
        report["real"] = {"points": [flown(n, "medium", sitl) for n in real]}
    else:
        report["real"] = {"skipped": "no PX4 SITL binary (MCS_PX4_BINARY)"}

    for level, g in report["growth"].items():
        print(f"{level}: exponent {g['exponent']:.2f}, {g['per_vehicle'] * 1e3:.1f} ms per vehicle")
        for p in g["points"]:
            print(
                f"  {p['vehicles']:2d} vehicles  {p['per_sim_s'] * 1e3:8.1f} ms per simulated s"
                f"  ({p['speed_factor']:.1f}x real time)"
            )
    for level, o in report["one_vehicle"].items():
        per = o["per_sim_s"]
        print(
            f"one vehicle, {level}: fleet of one / px4.PX4 = {o['ratio']:.2f} "
            f"({per['fleet of one'] * 1e3:.1f} / {per['px4.PX4'] * 1e3:.1f} ms per simulated s)"
        )
    for p in report["real"].get("points", []):
        print(f"real PX4 x{p['vehicles']}: {p['speed_factor']:.2f}x real time")
    out = write_result("fleet", report, args.output)
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
