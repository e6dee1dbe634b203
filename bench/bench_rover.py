"""Rover scenario speed: a 60 s mission at each fidelity, and raw MuJoCo, in one run.

1. low: kinematic world + in-process controller (target >= 1000x real time);
2. medium: MuJoCo world and controller as separate processes in lockstep (target >= 20x);
3. high: MuJoCo at a five times finer step, world and controller as Docker containers
   (target >= 5x); with no Docker engine, as local processes (the reason is recorded);
4. raw MuJoCo: ``mujoco.mj_step(model, data, nstep=...)`` of the same model and world
   configuration for the same simulated time, once in one call and once in batches of one
   exchange period (what the world does between two lockstep exchanges), so the overhead of
   each level over the physics it simulates is visible.

Speed factor = simulated seconds / wall seconds of ``controller.send(mission)`` (start and
stop are timed separately). Usage: ``python bench/bench_rover.py [--repeat N] [--quick]``;
prints a table and writes ``bench/results/rover.json``.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import mujoco
from _common import docker_reason, write_result

import multicosim.rover as rover
from multicosim.physics import Physics

# About 60 s of simulated time: wait, 50 m, a right-angle turn, 55 m and stop, at 2 m/s.
MISSION = rover.Mission(
    speed=2.0, wait=5.0, distance=50.0, turn_angle=math.radians(90.0), final_distance=55.0
)
TARGETS = {"low": 1000.0, "medium": 20.0, "high": 5.0}


def run_mission(
    fidelity: rover.Fidelity,
    seed: int,
    placement: str | None = None,
    mission: rover.Mission = MISSION,
) -> dict[str, Any]:
    """One mission at ``fidelity``: start, send and stop wall times, simulated duration
    (``placement`` None: the fidelity's default)."""
    t0 = time.perf_counter()
    simulator = rover.Rover(fidelity=fidelity, placement=placement, seed=seed)
    simulation = simulator.start()
    t1 = time.perf_counter()
    try:
        trajectory = simulation.controller.send(mission)
        t2 = time.perf_counter()
    finally:
        simulation.stop()
    t3 = time.perf_counter()
    if not trajectory.completed:
        raise SystemExit(f"{fidelity}: the mission did not complete: {trajectory.reason}")
    # The clock also ran while the controller waited for its first sensor readings.
    simulated = trajectory.final.time
    return {
        "placement": simulator.placement.name,
        "start_s": t1 - t0,
        "send_s": t2 - t1,
        "stop_s": t3 - t2,
        "sim_s": simulated,
        "speed_factor": simulated / (t2 - t1),
    }


def raw_mujoco(fidelity: rover.Fidelity, duration: float, repeat: int = 3) -> dict[str, float]:
    """Raw ``mj_step`` of the rover model driving straight for ``duration`` simulated s."""
    config = rover.default_world(fidelity)
    total = round(duration / config.timestep)
    per_period = config.steps_per_period
    results: dict[str, float] = {"steps": float(total), "timestep": config.timestep}
    for label, batch in (("one_call_s", total), ("per_period_s", per_period)):
        times = []
        for _ in range(repeat):  # best of several: the first run pays for cold caches
            physics = Physics.from_xml_path(rover.RoverVehicle.model_path, config)
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


def high_placement() -> tuple[str, str | None]:
    """Docker where an engine runs and the rover takes it, else local processes and why."""
    reason = docker_reason()
    if reason is not None:
        return "process", reason
    try:
        rover.Rover(fidelity="high", placement="docker")
    except Exception as exc:
        return "process", f"the rover's docker placement is not available: {exc}"
    return "docker", None


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the table, write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per fidelity (best kept)")
    parser.add_argument("--quick", action="store_true", help="one run per level")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else args.repeat

    placement, fallback = high_placement()
    runs: dict[str, list[dict[str, Any]]] = {"low": [], "medium": [], "high": []}
    for i in range(repeat):
        # Interleaved, so that a slow phase of a shared machine hits every level alike.
        for _ in range(3):  # low is cheap: more tries for a stable best
            runs["low"].append(run_mission("low", seed=i))
        runs["medium"].append(run_mission("medium", seed=i))
        if i == 0 or not args.quick:
            runs["high"].append(run_mission("high", seed=i, placement=placement))

    best = {f: max(r, key=lambda x: x["speed_factor"]) for f, r in runs.items()}
    raw = {level: raw_mujoco(level, best[level]["sim_s"], repeat) for level in ("medium", "high")}
    levels: dict[str, Any] = {}
    for level, r in best.items():
        entry: dict[str, Any] = {
            **r,
            "median_speed_factor": statistics.median(x["speed_factor"] for x in runs[level]),
            "runs": len(runs[level]),
            "target": TARGETS[level],
            "world": {
                "timestep": rover.default_world(level).timestep,  # type: ignore[arg-type]
                "period": rover.default_world(level).period,  # type: ignore[arg-type]
            },
        }
        ref = raw.get(level, raw["medium"])
        entry["raw_mujoco_model"] = level if level in raw else "medium"
        entry["over_raw_one_call"] = r["send_s"] / ref["one_call_s"] * ref_scale(r, ref)
        entry["over_raw_per_period"] = r["send_s"] / ref["per_period_s"] * ref_scale(r, ref)
        levels[level] = entry
    levels["high"]["fallback_reason"] = fallback

    report: dict[str, Any] = {
        "mission": {"speed": MISSION.speed, "sim_s": best["medium"]["sim_s"]},
        "mujoco": mujoco.__version__,
        "repeat": repeat,
        "levels": levels,
        "raw_mujoco": raw,
    }
    print(f"rover 60 s mission, best of {repeat} (low: {3 * repeat})")
    print(f"{'run':<44} {'wall s':>8} {'sim s':>6} {'x real':>8} {'/ raw':>7}")
    for level, e in levels.items():
        label = f"{level} ({e['placement']})"
        print(
            f"{label:<44} {e['send_s']:>8.3f} {e['sim_s']:>6.1f} {e['speed_factor']:>8.0f}"
            f" {e['over_raw_one_call']:>7.1f}"
        )
    for level, r in raw.items():
        print(f"{'raw mj_step (' + level + ' model), one call':<44} {r['one_call_s']:>8.3f}")
    if fallback:
        print(f"high ran as local processes: {fallback}")
    out = write_result("rover", report, args.output)
    print(f"wrote {out.name}")
    return 0


def ref_scale(run: dict[str, Any], ref: dict[str, float]) -> float:
    """1, unless the raw run covered a different simulated time than ``run`` (rescale)."""
    raw_sim = ref["steps"] * ref["timestep"]
    return raw_sim / run["sim_s"] if raw_sim else 1.0


if __name__ == "__main__":
    sys.exit(main())
