"""What an FMU costs as a component, measured side by side with FMPy and raw ZeroMQ.

1. In-process: the per-step cost of ``fmi.simulate`` (one FMU on multicosim's clock, every
   output recorded) against ``fmpy.simulate_fmu``'s own co-simulation loop on the same FMU
   and step (VanDerPol, FMI 2 and FMI 3, 10 ms). Per step = the difference between a long
   and a short run over the difference in steps, so set-up (extraction, instantiation,
   starting the simulation) cancels out; CPU time of this process, which other programs on
   a shared machine do not inflate. Rounds alternate; the medians are compared. Target: at
   most 1.5 times FMPy's cost.
2. As a process: one lockstep step of the FMU in its own process (``advance(period)``)
   against a raw ZeroMQ ROUTER/DEALER round trip between two processes (the same peer as
   ``bench_transport.py``), beside the FMU's in-process step and the lockstep exchange of a
   participant process that does nothing: what the FMU's process adds.
3. Growth: the cost of a run with 1, 2, 4, 8 and 16 FMUs in one simulation, in-process (CPU
   time) and, unless ``--quick``, as processes (wall time); the fitted exponent of cost
   against the count is 1 for linear growth.

The Reference FMUs come from ``MCS_REFERENCE_FMUS`` or ``../shared/reference-fmus``; without
them the benchmark says so and measures nothing.

Usage: ``python bench/bench_fmi.py [--quick] [--rounds N]``; prints a table and writes
``bench/results/fmi.json``.
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import fmpy
import zmq
from _common import ROOT, fit_exponent, write_result
from bench_transport import HERE, STEP_PERIOD, RawPeer, run_rounds, summary

import multicosim as mcs
from multicosim import fmi
from multicosim.core import wire

TARGET_RATIO = 1.5
STEP = 0.01
COUNTS = (1, 2, 4, 8, 16)


def reference_fmus() -> Path | None:
    """The Reference FMUs' directory, or None."""
    named = os.environ.get("MCS_REFERENCE_FMUS")
    directory = Path(named) if named else ROOT.parent / "shared" / "reference-fmus"
    return directory if (directory / "fmi2").is_dir() else None


def per_step_in_process(path: Path, short: float, long: float, rounds: int) -> dict[str, Any]:
    """Per-step cost (us) of fmi.simulate and fmpy.simulate_fmu, from long minus short runs."""

    def ours(stop: float) -> float:
        t0 = time.process_time()
        fmi.simulate(path, stop_time=stop, step=STEP)
        return time.process_time() - t0

    def theirs(stop: float) -> float:
        t0 = time.process_time()
        fmpy.simulate_fmu(str(path), stop_time=stop, output_interval=STEP, fmi_type="CoSimulation")
        return time.process_time() - t0

    steps = round((long - short) / STEP)
    samples: dict[str, list[float]] = {"multicosim": [], "fmpy": []}
    ours(short), theirs(short)  # warm-up: imports, caches
    for r in range(rounds):
        order = [("multicosim", ours), ("fmpy", theirs)]
        for name, run in order if r % 2 == 0 else reversed(order):
            samples[name].append((run(long) - run(short)) / steps * 1e6)
    medians = {name: statistics.median(s) for name, s in samples.items()}
    return {
        "fmu": f"{path.parent.name}/{path.name}",
        "step_s": STEP,
        "steps_compared": steps,
        "per_step_us": medians,
        "samples_us": samples,
        "ratio": medians["multicosim"] / medians["fmpy"],
    }


def process_step(path: Path, iterations: int, rounds: int) -> dict[str, Any]:
    """One lockstep step of the FMU as a process vs a raw ROUTER/DEALER round trip."""
    in_process = mcs.ProcessSimulator()
    in_process.add(fmi.FMU(path, name="vdp", period=STEP, history=False))
    simulator = mcs.ProcessSimulator()
    simulator.add(fmi.FMU(path, name="vdp", period=STEP, placement="process", history=False))
    # The lockstep exchange alone: a participant process whose step does nothing.
    idle = mcs.ProcessSimulator()
    idle.add(
        mcs.ProcessComponent(
            "python -m multicosim participant bench_transport:Idle",
            name="idle",
            env={"PYTHONPATH": os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")])},
        )
    )
    zctx = zmq.Context()
    router = zctx.socket(zmq.ROUTER)
    port = router.bind_to_random_port("tcp://127.0.0.1")
    peer = RawPeer("dealer", f"tcp://127.0.0.1:{port}")
    ident, _hello = router.recv_multipart()
    step = wire.encoder.encode(wire.Step(10**9, []))
    try:
        with simulator.start() as sim, in_process.start() as local, idle.start() as nothing:
            sim.advance(STEP)  # the first advance also runs the t=0 step
            local.advance(STEP)
            nothing.advance(STEP_PERIOD)

            def raw() -> list[bytes]:
                router.send_multipart([ident, step])
                return router.recv_multipart()

            samples = run_rounds(
                {
                    "raw ROUTER/DEALER": raw,
                    "FMU as a process": lambda: sim.advance(STEP),
                    "FMU in-process": lambda: local.advance(STEP),
                    "idle participant as a process": lambda: nothing.advance(STEP_PERIOD),
                },
                iterations,
                rounds,
            )
    finally:
        router.close(0)
        zctx.term()
        peer.close()
    stats = {name: summary(s) for name, s in samples.items()}
    raw_us = stats["raw ROUTER/DEALER"]["median_us"]
    return {
        "fmu": f"{path.parent.name}/{path.name}",
        "stats": stats,
        "ratio": stats["FMU as a process"]["median_us"] / raw_us,
        # What the FMU's process adds to the exchange of a participant that does nothing,
        # beyond its own step.
        "added_us": stats["FMU as a process"]["median_us"]
        - stats["idle participant as a process"]["median_us"]
        - stats["FMU in-process"]["median_us"],
    }


def growth(path: Path, where: str, duration: float, repeat: int) -> dict[str, Any]:
    """Cost of ``advance(duration)`` with 1..16 FMUs in one simulation: CPU time of this
    process in-process, wall time with the FMUs as processes; the counts take turns, and
    each count's median over ``repeat`` runs is kept."""
    clock = time.process_time if where == "in-process" else time.perf_counter
    costs: dict[int, list[float]] = {count: [] for count in COUNTS}
    for r in range(repeat):
        for count in COUNTS if r % 2 == 0 else reversed(COUNTS):
            simulator = mcs.ProcessSimulator()
            for i in range(count):
                simulator.add(
                    fmi.FMU(path, name=f"vdp{i}", period=STEP, placement=where, history=False)
                )
            with simulator.start() as sim:
                sim.advance(10 * STEP)  # set-up and first steps are not the growth measured
                gc.collect()
                t0 = clock()
                sim.advance(duration)
                costs[count].append(clock() - t0)
    points = []
    for count in COUNTS:
        cost = statistics.median(costs[count])
        steps = round(duration / STEP) * count
        points.append({"fmus": count, "cost_s": cost, "per_fmu_step_us": cost / steps * 1e6})
    return {
        "where": where,
        "clock": "process CPU time" if where == "in-process" else "wall time",
        "duration_s": duration,
        "points": points,
        "exponent": fit_exponent([float(c) for c in COUNTS], [p["cost_s"] for p in points]),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="brief: fewer rounds, in-process")
    parser.add_argument("--rounds", type=int, default=15, help="alternating rounds per case")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    directory = reference_fmus()
    if directory is None:
        reason = "no Reference FMUs (MCS_REFERENCE_FMUS, or ../shared/reference-fmus)"
        print(f"skipped: {reason}")
        write_result("fmi", {"skipped": reason}, args.output)
        return 0
    rounds = 3 if args.quick else args.rounds
    started = time.perf_counter()
    short, long = (1.0, 3.0) if args.quick else (1.0, 21.0)
    in_process = [
        per_step_in_process(directory / version / "VanDerPol.fmu", short, long, rounds)
        for version in ("fmi2", "fmi3")
    ]
    for r in in_process:
        us = r["per_step_us"]
        print(
            f"{r['fmu']}: in-process {us['multicosim']:.1f} us per step, FMPy's loop "
            f"{us['fmpy']:.1f} us: ratio {r['ratio']:.2f} (target <= {TARGET_RATIO})"
        )
    path = directory / "fmi2" / "VanDerPol.fmu"
    iterations = 300 if args.quick else 4000
    process = process_step(path, iterations, rounds)
    s = process["stats"]
    print(
        f"{process['fmu']}: as a process {s['FMU as a process']['median_us']:.0f} us per step, "
        f"raw ROUTER/DEALER {s['raw ROUTER/DEALER']['median_us']:.0f} us, in-process "
        f"{s['FMU in-process']['median_us']:.1f} us, an idle participant process "
        f"{s['idle participant as a process']['median_us']:.0f} us: ratio {process['ratio']:.2f}"
    )
    grown = {
        "in-process": growth(
            path, "in-process", 1.0 if args.quick else 10.0, 1 if args.quick else 7
        )
    }
    if not args.quick:
        grown["process"] = growth(path, "process", 2.0, 3)
    for where, g in grown.items():
        print(f"growth, {where}: exponent {g['exponent']:.2f}")
        for p in g["points"]:
            print(
                f"  {p['fmus']:2d} FMUs  {p['cost_s']:7.3f} s  "
                f"{p['per_fmu_step_us']:6.1f} us per FMU step"
            )
    elapsed = time.perf_counter() - started
    result = {
        "target_ratio": TARGET_RATIO,
        "in_process": in_process,
        "process": process,
        "growth": grown,
        "versions": {"fmpy": fmpy.__version__},
        "elapsed_s": round(elapsed, 1),
    }
    out = write_result("fmi", result, args.output)
    print(f"wrote {out.name} (took {elapsed:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
