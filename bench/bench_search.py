"""The falsification benchmark: optimizers on rare violations, and multi-fidelity search.

The problems are ``scenarios/search_problems.py``'s (rover lane under a GPS spoof, rover
turn overshoot over mission, noise and world, PX4 geofence under a GPS spoof, PX4 altitude
under a barometer spoof). For each problem:

1. the violation rate: uniform samples at low fidelity, run as a campaign (process pool);
2. for each optimizer and each seed: one search at low fidelity with the problem's budget;
   the median number of simulations to the first violation (a search that found none counts
   as budget + 1) and the share of searches that found one;
3. multi-fidelity (``--mf``): the default optimizer searches at low and confirms at medium,
   against the same optimizer searching at medium alone, seed by seed: the wall time to a
   counterexample that medium fidelity confirms, and the transfer rate.

Usage: ``python bench/bench_search.py [--seeds N] [--problems a,b] [--optimizers a,b]
[--mf-seeds N] [--quick] [--readme]``. Writes ``bench/results/search.json``; ``--readme``
rewrites the README's search table (between ``<!-- search:start -->`` and
``<!-- search:end -->``) from it. Simulations are deterministic for a seed, so the counts
do not depend on the machine; wall times do (measured on a shared 2-core machine).
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _common import ROOT, write_result

sys.path.insert(0, str(ROOT / "scenarios"))

from search_problems import PROBLEMS, Problem

from multicosim.campaign import run_campaign
from multicosim.falsify import (
    DEFAULT_OPTIMIZER,
    OPTIMIZERS,
    Choice,
    HypothesisSearch,
    Integer,
    Real,
    first_violation_statistics,
)

README = ROOT / "README.md"
START, END = "<!-- search:start -->", "<!-- search:end -->"
RATE_SAMPLES = 2000


def uniform(space: dict[str, Any], n: int, seed: int) -> list[dict[str, Any]]:
    """``n`` samples drawn uniformly from ``space`` (what uniform random search draws)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        sample: dict[str, Any] = {}
        for name, dim in space.items():
            if isinstance(dim, Choice):
                sample[name] = dim.values[int(rng.integers(len(dim.values)))]
            elif isinstance(dim, Integer):
                sample[name] = int(rng.integers(dim.low, dim.high + 1))
            else:
                lo, hi = (dim.low, dim.high) if isinstance(dim, Real) else dim
                sample[name] = float(rng.uniform(lo, hi))
        out.append(sample)
    return out


def violation_rate(problem: Problem, n: int) -> dict[str, Any]:
    samples = uniform(dict(problem.space), n, seed=12345)
    started = time.perf_counter()
    result = run_campaign(
        problem.simulate, problem.requirement, samples, fidelity="low", progress=False
    )
    violated = len(result.violations)
    # A Wilson 95 % interval: the rate is an estimate from n samples.
    p, z = violated / n, 1.96
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return {
        "samples": n,
        "violations": violated,
        "errors": len(result.failures),
        "rate": p,
        "rate_95": [max(0.0, centre - half), centre + half],
        "wall_s": time.perf_counter() - started,
    }


def optimizer_arg(name: str) -> Any:
    # Shrinking does not change the first violation; it only costs simulations after it.
    return HypothesisSearch(shrink=False) if name == "hypothesis" else name


def searches(problem: Problem, optimizer: str, seeds: int) -> dict[str, Any]:
    results = []
    started = time.perf_counter()
    for seed in range(seeds):
        results.append(problem.search(seed=seed, optimizer=optimizer_arg(optimizer)))
    wall = time.perf_counter() - started
    stats = first_violation_statistics(results)
    simulations = sum(r.simulations for r in results)
    return {
        **stats,
        "budget": problem.budget,
        "first_violation": [r.first_violation for r in results],
        "wall_s": wall,
        "ms_per_simulation": 1e3 * wall / max(simulations, 1),
    }


def multi_fidelity(problem: Problem, seeds: int, budget: int) -> dict[str, Any]:
    """Low then medium, against medium alone: wall time to a medium-confirmed violation."""
    rows = []
    for seed in range(seeds):
        both = problem.search(seed=seed, levels=("low", "medium"))
        alone = problem.search(seed=seed, levels=("medium",), budget=budget)
        medium = both.stats["medium"]
        rows.append(
            {
                "seed": seed,
                "multi_found": both.falsified,
                "multi_wall_s": both.wall_time,
                "multi_low_simulations": both.simulations,
                "multi_medium_runs": medium.runs,
                "tried": medium.tried,
                "transferred": medium.transferred,
                "alone_found": alone.falsified,
                "alone_wall_s": alone.wall_time,
                "alone_simulations": alone.simulations,
                "alone_budget": budget,
            }
        )
    tried = sum(r["tried"] for r in rows)
    multi = statistics.median(r["multi_wall_s"] for r in rows)
    alone = statistics.median(r["alone_wall_s"] for r in rows)
    return {
        "seeds": seeds,
        "medium_budget": budget,
        "multi_found": sum(r["multi_found"] for r in rows),
        "alone_found": sum(r["alone_found"] for r in rows),
        "multi_wall_median_s": multi,
        "alone_wall_median_s": alone,
        "speedup": alone / multi if multi > 0 else None,
        "transfer_rate": sum(r["transferred"] for r in rows) / tried if tried else None,
        "per_seed": rows,
    }


def table(data: dict[str, Any]) -> str:
    """The README's search table (markdown), from the results."""
    optimizers: list[str] = data["optimizers"]
    default = data["default"]
    lines = [
        START,
        f"Generated by `python bench/bench_search.py --readme` ({data['seeds']} seeds per "
        f"optimizer, low fidelity; machine: {data['machine']['cores']} cores, shared). Each "
        "cell: median simulations to the first violation (a search that found none counts "
        "as its budget + 1) / share of searches that found one within the budget.",
        "",
        "| problem | violating inputs | budget | "
        + " | ".join(f"`{o}`" + (" (default)" if o == default else "") for o in optimizers)
        + f" | random / `{default}` |",
        "|---|---|---|" + "---|" * len(optimizers) + "---|",
    ]
    for name, p in data["problems"].items():
        rate = p["rate"]
        cells = []
        for o in optimizers:
            s = p["optimizers"].get(o)
            cells.append("-" if s is None else f"{s['median']:g} / {100 * s['success_rate']:.0f} %")
        ratio = p.get("random_over_default")
        lines.append(
            f"| {name} | {100 * rate['rate']:.1f} % ({rate['violations']}/{rate['samples']}) "
            f"| {p['budget']} | " + " | ".join(cells) + f" | {ratio:.1f}x |"
            if ratio is not None
            else " | - |"
        )
    mf = data.get("multi_fidelity") or {}
    if mf:
        lines += [
            "",
            f"Multi-fidelity, `{default}` searching at low and confirming at medium, against "
            "the same search at medium alone (median wall time to a counterexample medium "
            "fidelity confirms):",
            "",
            "| problem | seeds | low + medium | medium alone | speed-up | transfer rate |",
            "|---|---|---|---|---|---|",
        ]
        for name, m in mf.items():
            rate = "-" if m["transfer_rate"] is None else f"{100 * m['transfer_rate']:.0f} %"
            lines.append(
                f"| {name} | {m['seeds']} | {m['multi_wall_median_s']:.1f} s "
                f"({m['multi_found']}/{m['seeds']} found) | {m['alone_wall_median_s']:.1f} s "
                f"({m['alone_found']}/{m['seeds']} found) | {m['speedup']:.1f}x | {rate} |"
            )
    lines.append(END)
    return "\n".join(lines)


def update_readme(section: str) -> None:
    text = README.read_text()
    head, start, rest = text.partition(START)
    _, end, tail = rest.partition(END)
    if not start or not end:
        raise SystemExit(f"README.md has no {START} ... {END} section")
    README.write_text(head + section + tail)


def save(
    optimizers: list[str],
    seeds: int,
    problems: dict[str, Any],
    mf: dict[str, Any],
    output: Path | None,
) -> Path:
    """Write what has been measured so far (a long run keeps its finished problems)."""
    data = {
        "default": DEFAULT_OPTIMIZER,
        "optimizers": optimizers,
        "seeds": seeds,
        "problems": problems,
        "multi_fidelity": mf,
    }
    return write_result("search", data, output)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--problems", default=",".join(PROBLEMS))
    parser.add_argument("--optimizers", default=",".join(OPTIMIZERS))
    parser.add_argument("--rate-samples", type=int, default=RATE_SAMPLES)
    parser.add_argument("--mf-seeds", type=int, default=5, help="multi-fidelity seeds (0: skip)")
    parser.add_argument("--mf-problems", default="rover-turn,px4-geofence")
    parser.add_argument(
        "--merge", action="store_true", help="keep the other problems of search.json"
    )
    parser.add_argument("--mf-budget", type=int, default=60, help="medium-alone budget")
    parser.add_argument("--quick", action="store_true", help="5 seeds, 2 problems")
    parser.add_argument("--readme", action="store_true", help="rewrite the README table")
    parser.add_argument("--from-results", action="store_true", help="only rewrite the table")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.from_results:
        import json

        from _common import RESULTS

        update_readme(table(json.loads((RESULTS / "search.json").read_text())))
        return 0
    if args.quick:
        args.seeds, args.rate_samples, args.mf_seeds = 5, 300, 1
        args.problems = args.mf_problems = "rover-lane,rover-turn"
    optimizers = args.optimizers.split(",")
    problems: dict[str, Any] = {}
    mf: dict[str, Any] = {}
    if args.merge:
        import json

        from _common import RESULTS

        previous = json.loads((RESULTS / "search.json").read_text())
        problems, mf = previous["problems"], previous["multi_fidelity"]
    for name in filter(None, args.problems.split(",")):
        problem = PROBLEMS[name]
        entry: dict[str, Any] = {"description": problem.description, "budget": problem.budget}
        entry["rate"] = violation_rate(problem, args.rate_samples)
        print(f"{name}: {100 * entry['rate']['rate']:.2f} % of inputs violate", flush=True)
        entry["optimizers"] = {}
        for optimizer in optimizers:
            s = searches(problem, optimizer, args.seeds)
            entry["optimizers"][optimizer] = s
            print(
                f"  {optimizer:>16}: median {s['median']:g}, found {s['found']}/{s['searches']}"
                f" ({s['wall_s']:.0f} s)",
                flush=True,
            )
        ops = entry["optimizers"]
        if "random" in ops and DEFAULT_OPTIMIZER in ops:
            entry["random_over_default"] = (
                ops["random"]["median"] / ops[DEFAULT_OPTIMIZER]["median"]
            )
        problems[name] = entry
        save(optimizers, args.seeds, problems, mf, args.output)
    if args.mf_seeds:
        for name in filter(None, args.mf_problems.split(",")):
            mf[name] = multi_fidelity(PROBLEMS[name], args.mf_seeds, args.mf_budget)
            m = mf[name]
            print(
                f"multi-fidelity {name}: {m['multi_wall_median_s']:.1f} s vs "
                f"{m['alone_wall_median_s']:.1f} s at medium alone ({m['speedup']:.1f}x), "
                f"transfer rate {m['transfer_rate']}",
                flush=True,
            )
            save(optimizers, args.seeds, problems, mf, args.output)
    out = save(optimizers, args.seeds, problems, mf, args.output)
    import json

    section = table(json.loads(out.read_text()))
    print(section)
    if args.readme:
        update_readme(section)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
