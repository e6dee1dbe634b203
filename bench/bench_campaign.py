"""Campaign throughput: the local process pool against Ray on the same machine.

A Latin-hypercube design of low-fidelity rover missions (``tests/campaign``'s simulate) runs
as a campaign twice with the same workers: in the process pool and as Ray tasks on a local
two-CPU cluster. Ray's per-task overhead is measured with an empty task against the median
simulation time.

Usage: ``python bench/bench_campaign.py [--samples N] [--quick]``. Prints a summary and
writes ``bench/results/campaign.json``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _common import ROOT, write_result

sys.path.insert(0, str(ROOT / "tests" / "campaign"))

import campaign_programs as cp

from multicosim.search.campaign import ProcessExecutor, RayExecutor, latin_hypercube, run_campaign


def _noop() -> None:
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=400, help="simulations per campaign")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="100 samples")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.quick:
        args.samples = 100
    design = latin_hypercube(cp.RANGES, args.samples, seed=1)
    out: dict[str, Any] = {"samples": args.samples, "workers": args.workers}

    pool = run_campaign(
        cp.simulate_rover,
        cp.REQUIREMENT,
        design,
        executor=ProcessExecutor(workers=args.workers),
        progress=False,
    )
    sim_ms = statistics.median(r.wall_time for r in pool.results) * 1e3
    out["process"] = {"wall_s": pool.wall_time, "per_minute": pool.rate_per_minute}
    out["simulation_ms_median"] = sim_ms

    import ray

    ray.cloudpickle.register_pickle_by_value(cp)
    ray.init(
        num_cpus=args.workers,
        include_dashboard=False,
        _node_ip_address="127.0.0.1",
        log_to_driver=False,
        configure_logging=False,
    )
    try:
        on_ray = run_campaign(
            cp.simulate_rover, cp.REQUIREMENT, design, executor=RayExecutor(), progress=False
        )
        out["ray"] = {"wall_s": on_ray.wall_time, "per_minute": on_ray.rate_per_minute}
        noop = ray.remote(_noop)
        ray.get([noop.remote() for _ in range(50)])  # warm the workers up
        started = time.perf_counter()
        ray.get([noop.remote() for _ in range(500)])
        # Throughput of empty tasks on all workers: the cost a task adds to a simulation.
        overhead_ms = (time.perf_counter() - started) / 500 * 1e3 * args.workers
        started = time.perf_counter()
        for _ in range(50):
            ray.get(noop.remote())
        latency_ms = (time.perf_counter() - started) / 50 * 1e3
    finally:
        ray.shutdown()
    out["ray_task_overhead_ms"] = overhead_ms
    out["ray_round_trip_ms"] = latency_ms
    out["ray_overhead_vs_simulation"] = overhead_ms / sim_ms
    out["ray_vs_process_throughput"] = out["ray"]["per_minute"] / out["process"]["per_minute"]
    path = write_result("campaign", out, args.output)
    print(
        f"{args.samples} low-fidelity rover simulations on {args.workers} workers: "
        f"process pool {out['process']['per_minute']:.0f}/min, "
        f"Ray {out['ray']['per_minute']:.0f}/min "
        f"({out['ray_vs_process_throughput']:.2f}x); simulation {sim_ms:.1f} ms (median), "
        f"Ray task overhead {overhead_ms:.2f} ms per task per worker "
        f"({100 * out['ray_overhead_vs_simulation']:.1f} % of a simulation), "
        f"round trip {latency_ms:.2f} ms\n-> {path}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
