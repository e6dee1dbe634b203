"""Real PX4 SITL on our world: its speed beside the built-in autopilot's, and the transfer.

1. speed: the PX4 benchmark's 60 s mission flown by real PX4 SITL (a process, lockstep on
   our MuJoCo world in this process) and by the built-in autopilot at medium fidelity, side
   by side in one run; for real PX4, where the wall time goes: waiting for PX4's answers
   (PX4's own computation and its scheduling), stepping the world (MuJoCo and the sensor
   messages), and the rest (the bridge's MAVLink encoding, the scheduler, the ground station);
2. transfer: the same 10 missions flown by the built-in autopilot at low and medium fidelity
   and by real PX4; per mission the distance between the built-in's true path and real
   PX4's (mean and max, horizontal), the time-to-complete ratio, whether the same
   waypoints were reached, and whether the verdict is the same (the mission completed, or
   not, on both). This says how well a cheap run predicts real PX4.

Needs a PX4 SITL binary: ``--px4-binary PATH`` or ``MCS_PX4_BINARY``; without one the
result says so. Usage: ``python bench/bench_sitl.py [--quick]``; prints a table and writes
``bench/results/sitl.json``.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import random
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _common import time_steps, write_result
from bench_px4 import PROJ, mission

import multicosim.px4 as px4

TARGET = 10.0  # simulated seconds per wall second, real PX4 in lockstep


def missions(count: int, seed: int = 7) -> list[px4.Configuration]:
    """``count`` missions of one to three waypoints within 60 m of home, ending in a landing."""
    rng = random.Random(seed)
    out = []
    for _ in range(count):
        wps = []
        for _ in range(rng.randint(1, 3)):
            lat, lon = PROJ.reproject(rng.uniform(-60, 60), rng.uniform(-60, 60))
            wps.append(px4.Waypoint(lat, lon, rng.uniform(8.0, 25.0)))
        out.append(px4.Configuration(wps, end="land", time_limit=240.0))
    return out


def fly(
    config: px4.Configuration, fidelity: str, sitl: px4.SITL | None
) -> tuple[px4.MissionResult, dict[str, float]]:
    """One mission; the result and wall times (send, and for real PX4 where it went)."""
    simulator = px4.PX4(fidelity=fidelity, firmware=sitl, seed=0)  # type: ignore[arg-type]
    with simulator.start() as simulation:
        world = simulation.world.participant if sitl is not None else None  # type: ignore[attr-defined]
        spent = time_steps(world) if world is not None else {"world_s": 0.0}
        t0 = time.perf_counter()
        result = simulation.firmware.send(config)
        wall = time.perf_counter() - t0
        times = {"send_s": wall, **spent}
        if sitl is not None:
            nodes = simulation.firmware.firmware_nodes
            assert nodes is not None
            bridge = nodes.bridges["px4.hil"].participant  # type: ignore[attr-defined]
            times["px4_s"] = bridge.wait_s
    assert result.completed, result.reason
    return result, times


def jitter(result: px4.MissionResult) -> float:
    """Mean change of roll and pitch between consecutive samples in the air (degrees)."""
    air = [s for s in result.trajectory if s.armed and s.true_alt > 2.0]
    steps = [abs(b.roll - a.roll) + abs(b.pitch - a.pitch) for a, b in itertools.pairwise(air)]
    return math.degrees(statistics.fmean(steps)) / 2.0 if steps else math.nan


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--px4-binary", default=os.environ.get("MCS_PX4_BINARY"))
    parser.add_argument("--quick", action="store_true", help="3 transfer missions, not 10")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    if not args.px4_binary:
        write_result("sitl", {"skipped": "no PX4 SITL binary (MCS_PX4_BINARY)"}, args.output)
        print("skipped: no PX4 SITL binary (--px4-binary or MCS_PX4_BINARY)")
        return 0
    sitl = px4.SITL(binary=args.px4_binary)

    # 1. speed, side by side
    speed: dict[str, Any] = {}
    for name, fidelity, firmware in (("real PX4", "medium", sitl), ("built-in", "medium", None)):
        result, times = fly(mission(), fidelity, firmware)
        speed[name] = {
            "sim_s": result.end_time,
            **times,
            "speed_factor": result.end_time / times["send_s"],
        }
    real = speed["real PX4"]
    real["target"] = TARGET
    real["share"] = {
        "px4": real["px4_s"] / real["send_s"],
        "world": real["world_s"] / real["send_s"],
        "rest": 1.0 - (real["px4_s"] + real["world_s"]) / real["send_s"],
    }

    # 2. transfer
    flights: list[dict[str, Any]] = []
    for i, config in enumerate(missions(3 if args.quick else 10)):
        ref, ref_times = fly(config, "medium", sitl)
        row: dict[str, Any] = {"mission": i, "waypoints": len(config.mission)}
        row["real PX4"] = {
            "duration_s": ref.duration,
            "wall_s": ref_times["send_s"],
            "jitter_deg": jitter(ref),
        }
        for level in ("low", "medium"):
            got, times = fly(config, level, None)
            mean, worst = got.path_gap(ref)
            row[level] = {
                "duration_s": got.duration,
                "wall_s": times["send_s"],
                "mean_distance_m": mean,
                "max_distance_m": worst,
                "time_ratio": got.duration / ref.duration,
                "same_waypoints": [r.index for r in got.reached] == [r.index for r in ref.reached],
                "same_verdict": got.completed == ref.completed,
                "jitter_deg": jitter(got),
            }
        flights.append(row)
    transfer = {
        level: {
            "mean_distance_m": statistics.fmean(f[level]["mean_distance_m"] for f in flights),
            "max_distance_m": max(f[level]["max_distance_m"] for f in flights),
            "time_ratio_mean": statistics.fmean(f[level]["time_ratio"] for f in flights),
            "time_ratio_range": [
                min(f[level]["time_ratio"] for f in flights),
                max(f[level]["time_ratio"] for f in flights),
            ],
            "same_waypoints": sum(f[level]["same_waypoints"] for f in flights),
            "same_verdict": sum(f[level]["same_verdict"] for f in flights),
            "missions": len(flights),
            "jitter_deg": statistics.fmean(f[level]["jitter_deg"] for f in flights),
        }
        for level in ("low", "medium")
    }
    # How much the attitude shakes in the same noisy world: the estimator's and controller's
    # response to sensor noise, beside real PX4's.
    real_jitter = statistics.fmean(f["real PX4"]["jitter_deg"] for f in flights)
    transfer["real PX4"] = {"jitter_deg": real_jitter}
    out = {"speed": speed, "transfer": transfer, "flights": flights}
    print(f"{'run':<12} {'sim s':>6} {'wall s':>7} {'x real':>7}")
    for name, r in speed.items():
        print(f"{name:<12} {r['sim_s']:6.1f} {r['send_s']:7.2f} {r['speed_factor']:7.1f}")
    sh = real["share"]
    print(
        f"real PX4 wall time: PX4 {sh['px4']:.0%}, world {sh['world']:.0%}, rest {sh['rest']:.0%}"
    )
    for level in ("low", "medium"):
        t = transfer[level]
        print(
            f"built-in {level} vs real PX4 over {t['missions']} missions: path distance mean "
            f"{t['mean_distance_m']:.2f} m, max {t['max_distance_m']:.2f} m; time ratio "
            f"{t['time_ratio_mean']:.2f}; same waypoints {t['same_waypoints']}/{t['missions']}; "
            f"same verdict {t['same_verdict']}/{t['missions']}"
        )
    print(
        "attitude jitter (mean change of roll and pitch per sample): built-in medium "
        f"{transfer['medium']['jitter_deg']:.3f} deg, real PX4 {real_jitter:.3f} deg"
    )
    path = write_result("sitl", out, args.output)
    print(f"wrote {path.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
