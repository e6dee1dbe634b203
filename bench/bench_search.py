"""The falsification benchmark: optimizers on rare violations, and multi-fidelity search.

The problems are ``scenarios/search_problems.py``'s (rover lane under a GPS spoof, rover
turn overshoot over mission, noise and world, PX4 geofence under a GPS spoof, PX4 altitude
under a barometer spoof). For each problem:

1. the violation rate: uniform samples at low fidelity, run as a campaign (process pool);
2. for each optimizer and each seed: one search at low fidelity with the problem's budget;
   the median number of simulations to the first violation (a search that found none counts
   as budget + 1) and the share of searches that found one;
3. multi-fidelity (``--mf-seeds``): a search at low (with the default optimizer and with
   ``tpe``, ``--mf-low``) that confirms at medium, against the default optimizer searching
   at medium alone, seed by seed (in turns, so that a change in the machine's load falls on
   all): the wall time to a counterexample that medium fidelity confirms, and the transfer
   rate;
4. real PX4 (``--real-seeds``, where ``--px4-binary`` or ``MCS_PX4_BINARY`` names PX4's SITL
   ``bin/px4``): the PX4 problems searched at low, confirmed at medium and on real PX4: the
   transfer rate per level, the verdict agreement (how many of the counterexamples the
   built-in autopilot confirmed at medium real PX4 confirmed too; each with its sample and
   its robustness on both), and the wall time against flying as many simulations on real PX4
   alone.

Usage: ``python bench/bench_search.py [--seeds N] [--problems a,b] [--optimizers a,b]
[--mf-seeds N] [--real-seeds N] [--quick] [--docs]``. Writes
``bench/results/search.json``; ``--docs`` rewrites the search table in docs/benchmarks.md (between
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
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from _common import BENCHMARKS_PAGE, ROOT, replace_section, write_result

sys.path.insert(0, str(ROOT / "scenarios"))

from search_problems import PROBLEMS, Problem

import multicosim.px4 as px4
from multicosim.search.campaign import run_campaign
from multicosim.search.falsify import (
    OPTIMIZERS,
    Choice,
    HypothesisSearch,
    Integer,
    Real,
    Trial,
    default_optimizer,
    falsify,
    first_violation_statistics,
)

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


def multi_fidelity(
    problem: Problem, seeds: int, budget: int, low_optimizers: list[str]
) -> dict[str, Any]:
    """Low then medium, against medium alone: wall time to a medium-confirmed violation.

    Medium alone searches with the default optimizer (fewest simulations, which costs least
    where simulations are slow); the low-fidelity search with each of ``low_optimizers``
    (where simulations are cheap, an optimizer's own time per sample counts as well).
    """
    default = default_optimizer()
    rows = []
    for seed in range(seeds):
        row: dict[str, Any] = {"seed": seed, "multi": {}}
        # In turns: the later runs on a warmer cache, or a machine less loaded.
        order: list[str | None] = [None, *low_optimizers]
        for name in order[seed % len(order) :] + order[: seed % len(order)]:
            if name is None:
                alone = problem.search(
                    seed=seed, levels=("medium",), budget=budget, optimizer=default
                )
                row.update(
                    alone_found=alone.falsified,
                    alone_wall_s=alone.wall_time,
                    alone_simulations=alone.simulations,
                )
                continue
            both = problem.search(seed=seed, levels=("low", "medium"), optimizer=name)
            medium = both.stats["medium"]
            row["multi"][name] = {
                "found": both.falsified,
                "wall_s": both.wall_time,
                "low_simulations": both.simulations,
                "low_wall_s": both.stats["low"].wall_time,
                "medium_runs": medium.runs,
                "tried": medium.tried,
                "transferred": medium.transferred,
            }
        rows.append(row)
        parts = ", ".join(
            f"{k} {m['wall_s']:.1f} s ({m['low_simulations']} low, {m['medium_runs']} medium)"
            for k, m in row["multi"].items()
        )
        print(
            f"  seed {seed}: low+medium {parts}; medium alone {row['alone_wall_s']:.1f} s "
            f"({row['alone_simulations']})",
            flush=True,
        )
    return mf_summary(rows, budget, default, low_optimizers)


def mf_summary(
    rows: list[dict[str, Any]], budget: int, default: str, low_optimizers: list[str]
) -> dict[str, Any]:
    """The multi-fidelity figures over the seeds' rows (see :func:`multi_fidelity`)."""
    alone = _found_median([(r["alone_wall_s"], r["alone_found"]) for r in rows])
    out: dict[str, Any] = {
        "seeds": len(rows),
        "medium_budget": budget,
        "alone_optimizer": default,
        "alone_found": sum(r["alone_found"] for r in rows),
        "alone_wall_median_s": alone,
        "alone_simulations_median": statistics.median(r["alone_simulations"] for r in rows),
        "low": {},
        "per_seed": rows,
    }
    for name in low_optimizers:
        ms = [r["multi"][name] for r in rows]
        tried = sum(m["tried"] for m in ms)
        multi = _found_median([(m["wall_s"], m["found"]) for m in ms])
        out["low"][name] = {
            "found": sum(m["found"] for m in ms),
            "wall_median_s": multi,
            "speedup": alone / multi if alone is not None and multi else None,
            "low_simulations_median": statistics.median(m["low_simulations"] for m in ms),
            "transferred": sum(m["transferred"] for m in ms),
            "tried": tried,
            "transfer_rate": sum(m["transferred"] for m in ms) / tried if tried else None,
        }
    return out


def _found_median(runs: list[tuple[float, bool]]) -> float | None:
    """The median wall time to a counterexample, a search that found none counting as
    endless (None: more than half found none)."""
    value = statistics.median(wall if found else math.inf for wall, found in runs)
    return None if math.isinf(value) else value


def agreement(trials: Sequence[Trial]) -> list[dict[str, Any]]:
    """Each counterexample the built-in autopilot confirmed at medium and real PX4 flew: the
    sample and its robustness at medium and on real PX4 (the verdicts agree where both are
    negative)."""
    medium = {t.search: t.robustness for t in trials if t.level == "medium"}
    return [
        {"search": t.search, "sample": t.sample, "medium": medium[t.search], "real": t.robustness}
        for t in trials
        if t.level == px4.SITL_LEVEL and t.search in medium
    ]


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
                "agreement": agreement(result.trials),
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


def _seconds(value: float | None) -> str:
    return "none found" if value is None else f"{value:.1f} s"


def _share(transferred: int, tried: int) -> str:
    return "-" if not tried else f"{transferred}/{tried} ({100 * transferred / tried:.0f} %)"


def table(data: dict[str, Any]) -> str:
    """The search table (markdown) of docs/benchmarks.md, from the results."""
    optimizers: list[str] = data["optimizers"]
    default = data["default"]
    lines = [
        START,
        "Generated by `python bench/bench_search.py --docs` (seeds per optimizer as the "
        f"row says, low fidelity; machine: {data['machine']['cores']} cores, shared). Each "
        "cell: median simulations to the first violation (a search that found none counts "
        "as its budget + 1) / share of searches that found one within the budget.",
        "",
        "| problem | violating inputs | budget | seeds | "
        + " | ".join(f"`{o}`" + (" (default)" if o == default else "") for o in optimizers)
        + f" | random / `{default}` |",
        "|---|---|---|---|" + "---|" * len(optimizers) + "---|",
    ]
    for name, p in data["problems"].items():
        rate = p["rate"]
        cells = []
        for o in optimizers:
            s = p["optimizers"].get(o)
            cells.append("-" if s is None else f"{s['median']:g} / {100 * s['success_rate']:.0f} %")
        ratio = p.get("random_over_default")
        searched = {s["searches"] for s in p["optimizers"].values()}
        lines.append(
            f"| {name} | {100 * rate['rate']:.1f} % ({rate['violations']}/{rate['samples']}) "
            f"| {p['budget']} | {'/'.join(map(str, sorted(searched)))} | "
            + " | ".join(cells)
            + (f" | {ratio:.1f}x |" if ratio is not None else " | - |")
        )
    mf = data.get("multi_fidelity") or {}
    if mf:
        first = next(iter(mf.values()))
        lines += [
            "",
            "Multi-fidelity: searching at low and confirming at medium, against searching at "
            f"medium alone (`{first['alone_optimizer']}`, budget {first['medium_budget']}), seed "
            "by seed and in turns: median wall time to a counterexample medium fidelity "
            "confirms (a search that found none counts as endless), median simulations, the "
            "speed-up (ratio of the medians) and the share of "
            "violations found at low that medium confirmed. The low-fidelity search runs with "
            f"`{first['alone_optimizer']}` and with `tpe`: where a simulation takes milliseconds, "
            "an optimizer's own time per sample counts as well as its number of samples.",
            "",
            "| problem | seeds | medium alone | low + medium | simulations (low; medium alone) "
            "| speed-up | transfer low to medium |",
            "|---|---|---|---|---|---|---|",
        ]
        for name, m in mf.items():
            for optimizer, low in m["low"].items():
                speedup = "-" if low["speedup"] is None else f"{low['speedup']:.1f}x"
                lines.append(
                    f"| {name} | {m['seeds']} | {_seconds(m['alone_wall_median_s'])} "
                    f"({m['alone_found']}/{m['seeds']} found) | `{optimizer}`: "
                    f"{_seconds(low['wall_median_s'])} ({low['found']}/{m['seeds']} found) | "
                    f"{low['low_simulations_median']:g}; {m['alone_simulations_median']:g} | "
                    f"{speedup} | {_share(low['transferred'], low['tried'])} |"
                )
    real = data.get("real_px4") or {}
    if real:
        lines += [
            "",
            f"Real PX4 SITL as the top level (`px4.sitl_level`): `{default}` searching at low, "
            "confirming at medium (built-in autopilot) and on real PX4 (v1.15.4 on the same "
            "MuJoCo world); per level, the violations from below that held there; the median "
            "wall time of a search to a counterexample real PX4 confirmed, against the same "
            "number of simulations flown on real PX4 alone (an estimate: simulations times the "
            "mean wall time of a real PX4 run):",
            "",
            "| problem | seeds | confirmed on real PX4 | medium | real PX4 | per real PX4 run "
            "| low + medium + real | real PX4 alone (est.) | saved |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for name, r in real.items():
            medium, top = r["levels"]["medium"], r["levels"][px4.SITL_LEVEL]
            per_run = top["mean_wall_s"]
            found = [x for x in r["per_seed"] if x["found"]]
            if per_run is None or not found:
                times = "- | - | -"
            else:
                wall = statistics.median(x["wall_s"] for x in found)
                alone = statistics.median(x["low_simulations"] * per_run for x in found)
                times = f"{wall:.0f} s | {alone:.0f} s | {alone / wall:.1f}x"
            lines.append(
                f"| {name} | {r['seeds']} | {r['found']}/{r['seeds']} "
                f"| {_share(medium['transferred'], medium['tried'])} "
                f"| {_share(top['transferred'], top['tried'])} "
                f"| {'-' if per_run is None else f'{per_run:.0f} s'} | {times} |"
            )
        lines += ["", verdict_agreement(real)]
    lines.append(END)
    return "\n".join(lines)


def verdict_agreement(real: dict[str, Any]) -> str:
    """The sentence under the real-PX4 table: how many of the counterexamples the built-in
    autopilot confirmed at medium real PX4 confirmed too (every one of them is flown there)."""
    counts = {
        name: (r["levels"][px4.SITL_LEVEL]["transferred"], r["levels"][px4.SITL_LEVEL]["tried"])
        for name, r in real.items()
    }
    held = sum(c[0] for c in counts.values())
    tried = sum(c[1] for c in counts.values())
    each = ", ".join(f"{name} {c[0]}/{c[1]}" for name, c in counts.items())
    return (
        f"Verdict agreement on the PX4 problems' counterexamples: real PX4 confirmed {held} of "
        f"the {tried} counterexamples the built-in autopilot found at medium ({each})."
    )


def update_docs(section: str) -> None:
    if not replace_section(BENCHMARKS_PAGE, START, END, section):
        raise SystemExit(f"{BENCHMARKS_PAGE.name} has no {START} ... {END} section")


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
        "--mf-low",
        default=f"{default_optimizer()},tpe",
        help="optimizers of the low-fidelity search in multi-fidelity",
    )
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
    parser.add_argument("--docs", action="store_true", help="rewrite the table in docs/")
    parser.add_argument("--from-results", action="store_true", help="only rewrite the table")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.from_results:
        import json

        from _common import RESULTS

        update_docs(table(json.loads((RESULTS / "search.json").read_text())))
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
            mf[name] = multi_fidelity(
                PROBLEMS[name], args.mf_seeds, args.mf_budget, args.mf_low.split(",")
            )
            for optimizer, low in mf[name]["low"].items():
                speedup = "-" if low["speedup"] is None else f"{low['speedup']:.1f}x"
                print(
                    f"  {optimizer}: {_seconds(low['wall_median_s'])} vs "
                    f"{_seconds(mf[name]['alone_wall_median_s'])} at medium alone "
                    f"({speedup}), transfer {low['transferred']}/{low['tried']}",
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
    if args.docs:
        update_docs(section)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
