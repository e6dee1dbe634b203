"""Rover scenario speed: a 60 s mission at low and medium fidelity, and raw MuJoCo, in one run.

1. low: kinematic world + in-process controller (target >= 1000x real time);
2. medium: MuJoCo world and controller as separate processes in lockstep (target >= 20x);
3. raw MuJoCo: ``mujoco.mj_step(model, data, nstep=...)`` of the same model and world
   configuration for the same simulated time, once in one call and once in batches of one
   exchange period (what the world does between two lockstep exchanges), so the medium
   run's overhead over the physics it simulates is visible.

Speed factor = simulated seconds / wall seconds of ``controller.send(mission)`` (start and
stop are timed separately). Usage: ``python bench/bench_rover.py [--repeat N]``; prints a
table and writes ``bench/results/rover.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import mujoco

import multicosim.rover as rover
from multicosim.mujoco import Physics, RoverVehicle

# About 60 s of simulated time: wait, 50 m, a right-angle turn, 55 m and stop, at 2 m/s.
MISSION = rover.Mission(
    speed=2.0, wait=5.0, distance=50.0, turn_angle=math.radians(90.0), final_distance=55.0
)
RESULTS = Path(__file__).parent / "results" / "rover.json"


def run_mission(fidelity: rover.Fidelity, seed: int) -> dict[str, float]:
    """One mission at ``fidelity``: start, send and stop wall times, simulated duration."""
    t0 = time.perf_counter()
    simulation = rover.Rover(fidelity=fidelity, seed=seed).start()
    t1 = time.perf_counter()
    try:
        trajectory = simulation.controller.send(MISSION)
        t2 = time.perf_counter()
    finally:
        simulation.stop()
    t3 = time.perf_counter()
    if not trajectory.completed:
        raise SystemExit(f"{fidelity}: the mission did not complete: {trajectory.reason}")
    simulated = trajectory.final.time - trajectory.start_time
    # The clock also ran while the controller waited for its first sensor readings.
    simulated_total = trajectory.final.time
    return {
        "start_s": t1 - t0,
        "send_s": t2 - t1,
        "stop_s": t3 - t2,
        "mission_sim_s": simulated,
        "sim_s": simulated_total,
        "speed_factor": simulated_total / (t2 - t1),
    }


def raw_mujoco(fidelity: rover.Fidelity, duration: float, repeat: int = 3) -> dict[str, float]:
    """Raw ``mj_step`` of the rover model driving straight for ``duration`` simulated s."""
    config = rover.default_world(fidelity)
    total = round(duration / config.timestep)
    per_period = config.steps_per_period
    results: dict[str, float] = {"steps": float(total)}
    for label, batch in (("one_call_s", total), ("per_period_s", per_period)):
        times = []
        for _ in range(repeat):  # best of several: the first run pays for cold caches
            physics = Physics.from_xml_path(RoverVehicle.model_path, config)
            physics.data.ctrl[:] = rover.ackermann(2.0, 0.0)
            model, data = physics.model, physics.data
            t0 = time.perf_counter()
            done = 0
            while done < total:
                n = min(batch, total - done)
                mujoco.mj_step(model, data, nstep=n)
                done += n
            times.append(time.perf_counter() - t0)
        results[label] = min(times)
    return results


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the table, write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per fidelity (best kept)")
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args(argv)

    runs: dict[str, list[dict[str, float]]] = {"low": [], "medium": []}
    for i in range(args.repeat):
        for fidelity in ("low", "medium"):
            runs[fidelity].append(run_mission(fidelity, seed=i))

    best = {f: max(r, key=lambda x: x["speed_factor"]) for f, r in runs.items()}
    medium = best["medium"]
    raw = raw_mujoco("medium", medium["sim_s"], args.repeat)
    report: dict[str, Any] = {
        "mission": {"speed": MISSION.speed, "sim_s": medium["mission_sim_s"]},
        "worlds": {
            f: {"timestep": w.timestep, "period": w.period}
            for f, w in (
                ("low", rover.default_world("low")),
                ("medium", rover.default_world("medium")),
            )
        },
        "python": sys.version.split()[0],
        "mujoco": mujoco.__version__,
        "machine": platform.machine(),
        "repeat": args.repeat,
        "low": {
            **best["low"],
            "median_speed_factor": statistics.median(r["speed_factor"] for r in runs["low"]),
        },
        "medium": {
            **medium,
            "median_speed_factor": statistics.median(r["speed_factor"] for r in runs["medium"]),
        },
        "raw_mujoco": raw,
        "medium_over_raw_one_call": medium["send_s"] / raw["one_call_s"],
        "medium_over_raw_per_period": medium["send_s"] / raw["per_period_s"],
    }

    rows = [
        ("low (kinematic, in-process)", best["low"]["send_s"], best["low"]["sim_s"]),
        ("medium (MuJoCo + controller processes)", medium["send_s"], medium["sim_s"]),
        ("raw mj_step, one call", raw["one_call_s"], medium["sim_s"]),
        ("raw mj_step, one batch per period", raw["per_period_s"], medium["sim_s"]),
    ]
    print(f"rover mission: {medium['mission_sim_s']:.1f} s simulated, best of {args.repeat}")
    print(f"{'run':<42} {'wall s':>9} {'sim s':>7} {'x real time':>12}")
    for name, wall, sim in rows:
        print(f"{name:<42} {wall:>9.4f} {sim:>7.1f} {sim / wall:>12.1f}")
    print(
        f"medium start {medium['start_s']:.3f} s, stop {medium['stop_s']:.3f} s; "
        f"medium / raw MuJoCo: {report['medium_over_raw_one_call']:.1f}x (one call), "
        f"{report['medium_over_raw_per_period']:.1f}x (per period)"
    )
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
