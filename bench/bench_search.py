"""The falsification benchmark: optimizers on rare violations, and multi-fidelity search.

The problems are ``scenarios/search_problems.py``'s (rover lane under a GPS spoof, rover
turn overshoot over mission, noise and world, PX4 geofence under a GPS spoof, PX4 altitude
under a barometer spoof). For each problem:

1. the violation rate: uniform samples at low fidelity, run as a campaign (process pool);
2. for each optimizer and each seed: one search at low fidelity with the problem's budget;
   the median number of simulations to the first violation (a search that found none counts
   as budget + 1) and the share of searches that found one;
3. multi-fidelity (``--mf-seeds``): the default optimizer searches at low and confirms at
   medium, against the same optimizer searching at medium alone, seed by seed (the two in
   turns, so that a change in the machine's load falls on both): the wall time to a
   counterexample that medium fidelity confirms, and the transfer rate;
4. real PX4 (``--real-seeds``, where ``--px4-binary`` or ``MCS_PX4_BINARY`` names PX4's SITL
   ``bin/px4``): the PX4 problems searched at low, confirmed at medium and on real PX4: the
   transfer rate per level.

Usage: ``python bench/bench_search.py [--seeds N] [--problems a,b] [--optimizers a,b]
[--mf-seeds N] [--real-seeds N] [--quick] [--readme]``. Writes
``bench/results/search.json``; ``--readme`` rewrites the README's search table (between
``<!-- search:start -->`` and ``<!-- search:end -->``) from it. Simulations with the built-in
autopilot are deterministic for a seed, so the counts do not depend on the machine; wall
times do (measured on a shared 2-core machine), and so, a little, do real PX4's (its modules
are threads).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _common import ROOT, write_result

sys.path.insert(0, str(ROOT / "scenarios"))

from search_problems import PROBLEMS, Problem

import multicosim.px4 as px4
from multicosim.campaign import run_campaign
from multicosim.falsify import (
    OPTIMIZERS,
    Choice,
    HypothesisSearch,
    Integer,
    Real,
    default_optimizer,
    falsify,
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


def warm_up() -> None:
    """Load what the default optimizer loads (torch for ``gp``) before anything is timed."""

    def simulate(sample: Any, fidelity: str, seed: int) -> dict[str, list[float]]:
        return {"time": [0.0], "x": [sample["x"]]}

    falsify(simulate, "always (x >= 0)", {"x": (0.0, 1.0)}, budget=12, levels=("low",))


def multi_fidelity(problem: Problem, seeds: int, budget: int) -> dict[str, Any]:
    """Low then medium, against medium alone: wall time to a medium-confirmed violation."""
    rows = []
    for seed in range(seeds):
        # In turns: the later of the two runs on a warmer cache, or a machine less loaded.
        if seed % 2:
            alone = problem.search(seed=seed, levels=("medium",), budget=budget)
            both = problem.search(seed=seed, levels=("low", "medium"))
        else:
            both = problem.search(seed=seed, levels=("low", "medium"))
            alone = problem.search(seed=seed, levels=("medium",), budget=budget)
        medium = both.stats["medium"]
        rows.append(
            {
                "seed": seed,
                "multi_found": both.falsified,
                "multi_wall_s": both.wall_time,
                "multi_low_simulations": both.simulations,
                "multi_low_wall_s": both.stats["low"].wall_time,
                "multi_medium_runs": medium.runs,
                "tried": medium.tried,
                "transferred": medium.transferred,
                "alone_found": alone.falsified,
                "alone_wall_s": alone.wall_time,
                "alone_simulations": alone.simulations,
                "alone_budget": budget,
            }
        )
        print(
            f"  seed {seed}: low+medium {both.wall_time:.1f} s ({both.simulations} low, "
            f"{medium.runs} medium), medium alone {alone.wall_time:.1f} s "
            f"({alone.simulations})",
            flush=True,
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
        # Per seed, then the median: how many times less wall time, searched side by side.
        "speedup_median": statistics.median(
            r["alone_wall_s"] / r["multi_wall_s"] for r in rows if r["multi_wall_s"] > 0
        ),
        "multi_low_simulations_median": statistics.median(r["multi_low_simulations"] for r in rows),
        "alone_simulations_median": statistics.median(r["alone_simulations"] for r in rows),
        "transfer_rate": sum(r["transferred"] for r in rows) / tried if tried else None,
        "transferred": sum(r["transferred"] for r in rows),
        "tried": tried,
        "per_seed": rows,
    }


def real_px4(problem: Problem, seeds: int, firmware: px4.SITL) -> dict[str, Any]:
    """Search at low, confirm at medium and on real PX4: the transfer rate per level."""
    rows = []
    for seed in range(seeds):
        result = problem.search(seed=seed, levels=problem.levels(firmware))
        stats = result.stats
        rows.append(
            {
                "seed": seed,
                "found": result.falsified,
                "low_simulations": result.simulations,
                "wall_s": result.wall_time,
                "levels": {
                    name: {
                        "runs": s.runs,
                        "tried": s.tried,
                        "transferred": s.transferred,
                        "wall_s": s.wall_time,
                    }
                    for name, s in stats.items()
                },
                "real_robustness": [
                    t.robustness for t in result.trials if t.level == px4.SITL_LEVEL
                ],
            }
        )
        rates = {k: f"{v['transferred']}/{v['tried']}" for k, v in rows[-1]["levels"].items()}
        print(f"  seed {seed}: {rates}, {result.wall_time:.0f} s", flush=True)
    levels: dict[str, Any] = {}
    for name in rows[0]["levels"]:
        runs = sum(r["levels"][name]["runs"] for r in rows)
        tried = sum(r["levels"][name]["tried"] for r in rows)
        transferred = sum(r["levels"][name]["transferred"] for r in rows)
        wall = sum(r["levels"][name]["wall_s"] for r in rows)
        levels[name] = {
            "runs": runs,
            "tried": tried,
            "transferred": transferred,
            "transfer_rate": transferred / tried if tried else None,
            "mean_wall_s": wall / runs if runs else None,
        }
    return {
        "seeds": seeds,
        "firmware": "PX4 SITL",
        "found": sum(r["found"] for r in rows),
        "levels": levels,
        "per_seed": rows,
    }


def _share(transferred: int, tried: int) -> str:
    return "-" if not tried else f"{transferred}/{tried} ({100 * transferred / tried:.0f} %)"


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
            f"| {p['budget']} | "
            + " | ".join(cells)
            + (f" | {ratio:.1f}x |" if ratio is not None else " | - |")
        )
    mf = data.get("multi_fidelity") or {}
    if mf:
        lines += [
            "",
            f"Multi-fidelity, `{default}` searching at low and confirming at medium, against "
            "the same search at medium alone (budget "
            f"{next(iter(mf.values()))['medium_budget']}), seed by seed: median wall time to a "
            "counterexample medium fidelity confirms, median simulations (at low; at medium "
            "alone), the speed-up (ratio of the medians) and the share of violations found at "
            "low that medium confirmed:",
            "",
            "| problem | seeds | low + medium | medium alone | simulations | speed-up "
            "| transfer low to medium |",
            "|---|---|---|---|---|---|---|",
        ]
        for name, m in mf.items():
            lines.append(
                f"| {name} | {m['seeds']} | {m['multi_wall_median_s']:.1f} s "
                f"({m['multi_found']}/{m['seeds']} found) | {m['alone_wall_median_s']:.1f} s "
                f"({m['alone_found']}/{m['seeds']} found) | "
                f"{m['multi_low_simulations_median']:g}; {m['alone_simulations_median']:g} | "
                f"{m['speedup']:.1f}x | {_share(m['transferred'], m['tried'])} |"
            )
    real = data.get("real_px4") or {}
    if real:
        lines += [
            "",
            f"Real PX4 SITL as the top level (`px4.sitl_level`): `{default}` searching at low, "
            "confirming at medium (built-in autopilot) and on real PX4 (v1.15.4 on the same "
            "MuJoCo world); per level, the violations from below that held there:",
            "",
            "| problem | seeds | confirmed on real PX4 | medium | real PX4 | wall time per real "
            "PX4 run |",
            "|---|---|---|---|---|---|",
        ]
        for name, r in real.items():
            medium, top = r["levels"]["medium"], r["levels"][px4.SITL_LEVEL]
            per_run = "-" if top["mean_wall_s"] is None else f"{top['mean_wall_s']:.0f} s"
            lines.append(
                f"| {name} | {r['seeds']} | {r['found']}/{r['seeds']} "
                f"| {_share(medium['transferred'], medium['tried'])} "
                f"| {_share(top['transferred'], top['tried'])} | {per_run} |"
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
    real: dict[str, Any],
    output: Path | None,
) -> Path:
    """Write what has been measured so far (a long run keeps its finished problems)."""
    data = {
        "default": default_optimizer(),
        "optimizers": optimizers,
        "seeds": seeds,
        "problems": problems,
        "multi_fidelity": mf,
        "real_px4": real,
    }
    return write_result("search", data, output)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--problems", default=",".join(PROBLEMS))
    parser.add_argument("--optimizers", default=",".join(OPTIMIZERS))
    parser.add_argument("--rate-samples", type=int, default=RATE_SAMPLES)
    parser.add_argument("--mf-seeds", type=int, default=10, help="multi-fidelity seeds (0: skip)")
    parser.add_argument("--mf-problems", default=",".join(PROBLEMS))
    parser.add_argument("--mf-budget", type=int, default=60, help="medium-alone budget")
    parser.add_argument(
        "--px4-binary",
        default=os.environ.get("MCS_PX4_BINARY"),
        help="real PX4 SITL's bin/px4 (default: MCS_PX4_BINARY)",
    )
    parser.add_argument("--real-seeds", type=int, default=5, help="real-PX4 seeds (0: skip)")
    parser.add_argument(
        "--real-problems", default=",".join(n for n, p in PROBLEMS.items() if p.flies_px4)
    )
    parser.add_argument(
        "--merge", action="store_true", help="keep what search.json has of the rest"
    )
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
        args.seeds, args.rate_samples, args.mf_seeds, args.real_seeds = 5, 300, 1, 1
        args.problems = args.mf_problems = "rover-lane,rover-turn"
        args.real_problems = "px4-geofence"
    firmware = px4.SITL(binary=args.px4_binary) if args.px4_binary and args.real_seeds else None
    optimizers = args.optimizers.split(",")
    problems: dict[str, Any] = {}
    mf: dict[str, Any] = {}
    real: dict[str, Any] = {}
    if args.merge:
        import json

        from _common import RESULTS

        previous = json.loads((RESULTS / "search.json").read_text())
        problems, mf = previous["problems"], previous["multi_fidelity"]
        real = previous.get("real_px4", {})
    default = default_optimizer()
    warm_up()
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
        if "random" in ops and default in ops:
            entry["random_over_default"] = ops["random"]["median"] / ops[default]["median"]
        problems[name] = entry
        save(optimizers, args.seeds, problems, mf, real, args.output)
    if args.mf_seeds:
        for name in filter(None, args.mf_problems.split(",")):
            print(f"multi-fidelity {name}:", flush=True)
            mf[name] = multi_fidelity(PROBLEMS[name], args.mf_seeds, args.mf_budget)
            m = mf[name]
            print(
                f"  {m['multi_wall_median_s']:.1f} s vs {m['alone_wall_median_s']:.1f} s at "
                f"medium alone ({m['speedup']:.1f}x), transfer {m['transferred']}/{m['tried']}",
                flush=True,
            )
            save(optimizers, args.seeds, problems, mf, real, args.output)
    if firmware is not None:
        for name in filter(None, args.real_problems.split(",")):
            print(f"real PX4 {name}:", flush=True)
            real[name] = real_px4(PROBLEMS[name], args.real_seeds, firmware)
            save(optimizers, args.seeds, problems, mf, real, args.output)
    elif args.real_seeds:
        print("no real PX4 (give --px4-binary or MCS_PX4_BINARY): its level is not measured")
    out = save(optimizers, args.seeds, problems, mf, real, args.output)
    import json

    section = table(json.loads(out.read_text()))
    print(section)
    if args.readme:
        update_readme(section)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
