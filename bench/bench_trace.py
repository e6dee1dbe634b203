"""Cost of recording a simulation's topics, at low fidelity (the cheapest runs).

A 60 s rover mission at low fidelity (kinematic world, controller in-process) takes a few
tens of milliseconds; recording every topic must add at most 10 % to that. Runs alternate
between recording and not (same seed, same mission) so drifts in machine speed hit both;
every run starts after a full garbage collection; time is this process's CPU time
(``time.process_time``), so other work on a shared machine does not count; the overhead is
the median of the per-pair ratios.
Saving the trace (JSON encoding, MCAP writing: done only for failing tests) is reported
separately.

Usage: ``python bench/bench_trace.py [--runs N] [--quick]``. Prints a table and writes
``bench/results/trace.json``.
"""

from __future__ import annotations

import argparse
import gc
import statistics
import tempfile
import time
from pathlib import Path

from _common import write_result

import multicosim.rover as rover
from multicosim.trace import Recorder, location_fix

TARGET_PERCENT = 10.0
# About 60 s of simulated time: wait 5 s, 25 m straight, a 70 degree turn, 25 m, stop.
MISSION = rover.Mission(speed=1.0, wait=5.0, distance=25.0, final_distance=25.0)


def one_run(record: bool) -> tuple[float, float, Recorder | None]:
    # Start both kinds from the same collector state: the previous run's garbage (and a
    # previous recording being freed) must not be charged to whichever run comes next.
    gc.collect()
    started = time.process_time()
    simulation = rover.Rover(fidelity="low", seed=0).start()
    recorder = Recorder().attach(simulation) if record else None
    try:
        trajectory = simulation.controller.send(MISSION)
    finally:
        simulation.stop()
    wall = time.process_time() - started
    if recorder is not None:
        recorder.add_trajectory(trajectory)
    return wall, trajectory.samples[-1].time, recorder


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=60, help="runs of each kind (default 60)")
    parser.add_argument("--quick", action="store_true", help="20 runs of each kind")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.quick:
        args.runs = 20

    one_run(False)  # warm-up: imports, caches
    plain: list[float] = []
    recorded: list[float] = []
    recorder: Recorder | None = None
    simulated = 0.0
    for _ in range(args.runs):
        recorder = None  # freed before the next pair, outside the timed region
        wall, simulated, _unused = one_run(False)
        plain.append(wall)
        wall, simulated, recorder = one_run(True)
        recorded.append(wall)
    assert recorder is not None
    recorder.converters.append(
        location_fix("rover/position", lambda m: (m["latitude"], m["longitude"], m["altitude"]))
    )
    with tempfile.TemporaryDirectory() as tmp:
        started = time.process_time()
        path = recorder.save(Path(tmp) / "run.mcap", seed=0, fidelity="low")
        save_s = time.process_time() - started
        size = path.stat().st_size

    p, r = statistics.median(plain), statistics.median(recorded)
    ratio = statistics.median(b / a for a, b in zip(plain, recorded, strict=True))
    report = {
        "mission_simulated_s": simulated,
        "messages_recorded": len(recorder.deliveries),
        "runs": args.runs,
        "cpu_s": {"plain_median": p, "recorded_median": r, "plain": plain, "recorded": recorded},
        "overhead_percent": 100.0 * (ratio - 1.0),
        "target_percent": TARGET_PERCENT,
        "save": {
            "seconds": save_s,
            "bytes": size,
            "messages_per_s": (len(recorder.deliveries) + len(recorder._extras)) / save_s,
        },
    }
    out = write_result("trace", report, args.output)
    print(
        f"60 s rover mission at low fidelity, {len(recorder.deliveries)} messages, "
        f"median of {args.runs} runs"
    )
    print(f"  without recording {1e3 * p:8.2f} ms CPU")
    print(f"  with recording    {1e3 * r:8.2f} ms CPU")
    print(f"  overhead (median of paired ratios) {report['overhead_percent']:+.1f} %")
    print(f"  save (MCAP, zstd, + LocationFix) {1e3 * save_s:.1f} ms, {size / 1024:.0f} KiB")
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
