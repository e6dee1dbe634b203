"""How cost grows: wall time and peak memory against mission length and component count.

1. Mission length: the rover mission of ``bench_rover.py`` scaled to about 30, 60, 120 and
   240 s of simulated time (waits and distances scaled alike), at low fidelity (and medium
   unless ``--quick``).
2. Components: 0, 1, 2, 4 and 8 pass-through relays chained between the world's position
   sensor and the controller (``bench/_relay.py``: world -> relay 1 -> ... -> controller),
   the 60 s mission, at low fidelity in-process (and medium, relays as processes, unless
   ``--quick``).

Wall time is that of ``controller.send`` (best of ``--repeat``); peak memory is the peak of
the Python heap during ``send`` (``tracemalloc``, in a separate run so that tracing does
not slow the timed one; low fidelity only, where everything runs in this process). The
fitted exponent is the slope of log(cost) against log(size): 1 is linear. For components,
the exponent is fitted to the cost the relays add over the run without any.

Usage: ``python bench/bench_scaling.py [--quick] [--repeat N]``; prints a table and writes
``bench/results/scaling.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
import tracemalloc
from pathlib import Path
from typing import Any

import msgspec
from _common import ROOT, fit_exponent, fit_linear, python_env, write_result
from _relay import Relay, RelayConfig

import multicosim as mcs
import multicosim.rover as rover

LENGTHS = (30.0, 60.0, 120.0, 240.0)
COMPONENTS = (0, 1, 2, 4, 8)
POSITION = rover.SENSOR_TOPICS["position"]


def mission(seconds: float) -> rover.Mission:
    """The 60 s mission scaled to about ``seconds`` of simulated time."""
    k = seconds / 60.0
    return rover.Mission(
        speed=2.0,
        wait=5.0 * k,
        distance=50.0 * k,
        turn_angle=math.radians(90.0),
        final_distance=55.0 * k,
        timeout=2.0 * seconds + 60.0,
    )


def simulator(fidelity: rover.Fidelity, relays: int) -> rover.Rover:
    """The rover with ``relays`` relays chained between the position sensor and its reader."""
    world = rover.default_world(fidelity)
    if relays:  # the world publishes its position where the first relay reads it
        world = dataclasses.replace(world, sensor_topics={"position": "bench/pos/0"})
    sim = rover.Rover(fidelity=fidelity, seed=0, world=world)
    for i in range(relays):
        config = RelayConfig(
            source=f"bench/pos/{i}",
            target=POSITION if i == relays - 1 else f"bench/pos/{i + 1}",
            period=world.period,
        )
        if fidelity == "low":
            sim.add(mcs.InProcessComponent(lambda c=config: Relay(c), name=f"relay{i}"))
        else:
            command = [
                "python",
                "-m",
                "multicosim",
                "participant",
                "_relay:relay",
                "--config",
                msgspec.json.encode(config).decode(),
            ]
            sim.add(
                mcs.ProcessComponent(
                    command, name=f"relay{i}", env=python_env(ROOT / "bench", ROOT)
                )
            )
    return sim


def run(fidelity: rover.Fidelity, relays: int, m: rover.Mission, memory: bool) -> dict[str, Any]:
    """One mission: wall time of ``send``, simulated time, and (if asked) peak heap."""
    simulation = simulator(fidelity, relays).start()
    try:
        if memory:
            tracemalloc.start()
        t0 = time.perf_counter()
        trajectory = simulation.controller.send(m)
        wall = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1] if memory else None
    finally:
        if memory:
            tracemalloc.stop()
        simulation.stop()
    assert trajectory.completed, trajectory.reason
    return {"wall_s": wall, "sim_s": trajectory.final.time, "peak_bytes": peak}


def series(
    fidelity: rover.Fidelity, points: list[tuple[int, rover.Mission]], repeat: int, memory: bool
) -> list[dict[str, Any]]:
    """Best-of-``repeat`` wall time per point, rounds interleaved; peak heap once per point."""
    best: list[dict[str, Any]] = [{} for _ in points]
    for _ in range(repeat):
        for i, (relays, m) in enumerate(points):
            r = run(fidelity, relays, m, memory=False)
            if not best[i] or r["wall_s"] < best[i]["wall_s"]:
                best[i] = r
    if memory:
        for i, (relays, m) in enumerate(points):
            best[i]["peak_bytes"] = run(fidelity, relays, m, memory=True)["peak_bytes"]
    return best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="low fidelity only")
    parser.add_argument("--repeat", type=int, default=3, help="runs per point at low fidelity")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    levels: tuple[rover.Fidelity, ...] = ("low",) if args.quick else ("low", "medium")

    report: dict[str, Any] = {"length": {}, "components": {}}
    for level in levels:
        repeat = args.repeat if level == "low" else 2
        memory = level == "low"
        rows = series(level, [(0, mission(s)) for s in LENGTHS], repeat, memory)
        for s, r in zip(LENGTHS, rows, strict=True):
            r["target_s"] = s
        sims = [r["sim_s"] for r in rows]
        entry: dict[str, Any] = {
            "points": rows,
            "time_exponent": fit_exponent(sims, [r["wall_s"] for r in rows]),
        }
        if memory:
            entry["memory_exponent"] = fit_exponent(sims, [r["peak_bytes"] for r in rows])
        report["length"][level] = entry

        rows = series(level, [(n, mission(60.0)) for n in COMPONENTS], repeat, memory)
        for n, r in zip(COMPONENTS, rows, strict=True):
            r["components"] = n
        base = rows[0]["wall_s"]
        added = [(r["components"], r["wall_s"] - base) for r in rows[1:]]
        entry = {
            "points": rows,
            "time_exponent": fit_exponent([n for n, _ in added], [max(a, 1e-9) for _, a in added]),
            # The slope of a straight line through every point: seconds per component.
            "per_component_s": fit_linear(
                [float(r["components"]) for r in rows], [r["wall_s"] for r in rows]
            )[1],
            "negative_added_cost": any(a <= 0 for _, a in added),
        }
        if memory:
            extra = [(r["components"], r["peak_bytes"] - rows[0]["peak_bytes"]) for r in rows[1:]]
            entry["memory_exponent"] = fit_exponent(
                [n for n, _ in extra], [max(b, 1) for _, b in extra]
            )
        report["components"][level] = entry

    for level, e in report["length"].items():
        print(f"mission length, {level}: time exponent {e['time_exponent']:.2f}", end="")
        print(f", memory exponent {e['memory_exponent']:.2f}" if "memory_exponent" in e else "")
        for r in e["points"]:
            mem = f"{r['peak_bytes'] / 1e6:8.2f} MB" if r.get("peak_bytes") else ""
            print(f"  {r['sim_s']:7.1f} s simulated  {r['wall_s']:8.3f} s wall  {mem}")
    for level, e in report["components"].items():
        print(f"components, {level}: added-cost exponent {e['time_exponent']:.2f}", end="")
        print(f", memory exponent {e['memory_exponent']:.2f}" if "memory_exponent" in e else "")
        for r in e["points"]:
            mem = f"{r['peak_bytes'] / 1e6:8.2f} MB" if r.get("peak_bytes") else ""
            print(f"  {r['components']:2d} relays  {r['wall_s']:8.3f} s wall  {mem}")
    out = write_result("scaling", report, args.output)
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
