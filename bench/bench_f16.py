"""The ARCH-COMP "F16" benchmark on AeroBench: simulations per result, per fidelity level.

1. one flight per level (the ARCH-COMP worst corner, from 4040 ft): wall time, in this process
   and as a local process, and how low it flies;
2. ARCH-COMP's instance (4040 ft, budget 300): a search at each level alone; the simulations
   it ran, whether it found a violation, the lowest robustness (ft) it saw and where;
3. the instance lowered to 2330 ft (psy-taliro's F-16 example): at each level alone, the
   median simulations to the first violation over ``--seeds`` seeds (a search that found none
   counts as budget + 1) and the share that found one; then searched at low and confirmed at
   medium and high: simulations at low, re-runs and transfers per level, the wall time.

Usage: ``python bench/bench_f16.py [--aerobench DIR] [--seeds N] [--budget N] [--quick]
[--docs]``; AeroBench comes from ``--aerobench``, ``MCS_AEROBENCH_DIR``, or
``../shared/aerobench`` beside the project. Writes ``bench/results/f16.json``; ``--docs``
rewrites the figures in docs/how-to/aerobench.md (between ``<!-- f16:start -->`` and
``<!-- f16:end -->``). Flights are deterministic, so the counts do not depend on the machine;
wall times do (measured on a shared 2-core machine).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _common import RESULTS, ROOT, replace_section, write_result

from multicosim import ConfigurationError
from multicosim.f16 import F16, FIDELITY_KNOBS, AeroBench, arch
from multicosim.search.falsify import default_optimizer, first_violation_statistics

START, END = "<!-- f16:start -->", "<!-- f16:end -->"
PAGE = ROOT / "docs" / "how-to" / "aerobench.md"
LEVELS = ("low", "medium", "high")
LOWERED = 2330.0
CORNER = {"roll": arch.SPACE["roll"][1], "pitch": arch.SPACE["pitch"][0], "yaw": -math.pi / 4}


def flights(aerobench: AeroBench, repeats: int) -> dict[str, Any]:
    """One flight of the worst corner per level and placement: median wall time, lowest."""
    benchmark = arch.Benchmark(aerobench)
    out: dict[str, Any] = {}
    for level in LEVELS:
        row: dict[str, Any] = {}
        for placement in ("in-process", "process"):
            walls = []
            # The first flight of a process imports scipy and AeroBench: not what is timed.
            for _ in range(repeats + (placement == "in-process" and level == LEVELS[0])):
                started = time.perf_counter()
                flight = F16(
                    level,
                    placement=placement,
                    aerobench=aerobench,
                    initial=benchmark.initial(CORNER),
                ).fly()
                walls.append(time.perf_counter() - started)
            row[placement] = statistics.median(walls[-repeats:])
        row["samples"] = len(flight)
        row["lowest_ft"] = flight.lowest.altitude
        row["lowest_at_s"] = flight.lowest.time
        out[level] = row
        print(f"  {level}: {row}", flush=True)
    return out


def arch_instance(
    aerobench: AeroBench, budget: int, optimizer: str, placement: str
) -> dict[str, Any]:
    """ARCH-COMP's instance, each level searched alone with one seed."""
    benchmark = arch.Benchmark(aerobench, placement=placement)
    out: dict[str, Any] = {}
    for level in LEVELS:
        result = benchmark.falsify(levels=(level,), budget=budget, optimizer=optimizer)
        lowest, sample = result.lowest or (math.nan, None)
        out[level] = {
            "simulations": result.simulations,
            "first_violation": result.first_violation,
            "lowest_robustness_ft": lowest,
            "lowest_sample": sample,
            "wall_s": result.wall_time,
        }
        print(f"  {level}: {out[level]}", flush=True)
    return out


def lowered(
    aerobench: AeroBench, budget: int, optimizer: str, seeds: int, placement: str
) -> dict[str, Any]:
    """The instance from 2330 ft: each level alone, then low confirmed at medium and high."""
    benchmark = arch.Benchmark(aerobench, altitude=LOWERED, placement=placement)
    out: dict[str, Any] = {"alone": {}, "multi": []}
    for level in LEVELS:
        results = [
            benchmark.falsify(levels=(level,), budget=budget, optimizer=optimizer, seed=seed)
            for seed in range(seeds)
        ]
        out["alone"][level] = {
            **first_violation_statistics(results),
            "first_violation": [r.first_violation for r in results],
            "wall_median_s": statistics.median(r.wall_time for r in results),
        }
        print(f"  {level} alone: {out['alone'][level]}", flush=True)
    for seed in range(seeds):
        result = benchmark.falsify(levels=LEVELS, budget=budget, optimizer=optimizer, seed=seed)
        row = {
            "seed": seed,
            "found": result.counterexample is not None,
            "simulations": result.simulations,
            "first_violation": result.first_violation,
            "first_confirmed": result.first_confirmed,
            "levels": {
                name: {"runs": s.runs, "tried": s.tried, "transferred": s.transferred}
                for name, s in result.stats.items()
            },
            "counterexample": result.counterexample.example if result.counterexample else None,
            "wall_s": result.wall_time,
        }
        out["multi"].append(row)
        print(f"  low+medium+high seed {seed}: {row}", flush=True)
    return out


def _fmt_sample(sample: Any) -> str:
    if not sample:
        return "-"
    return ", ".join(f"{k} {v / math.pi:.4f} pi" for k, v in sample.items())


def table(data: dict[str, Any]) -> str:
    """The figures as Markdown, between the markers."""
    lines = [
        START,
        f"Generated by `python bench/bench_f16.py --docs` (optimizer `{data['optimizer']}`, "
        f"budget {data['budget']}, searches flown `{data['placement']}`; machine: "
        f"{data['machine']['cores']} cores, shared).",
        "",
        "One flight (15 s) of the worst corner of the inputs (roll 0.2833 pi, pitch -0.4 pi) "
        "from 4040 ft, median wall time:",
        "",
        "| level | knobs | samples | in-process | process | lowest altitude |",
        "|---|---|---|---|---|---|",
    ]
    for level, row in data["flights"].items():
        knobs = data["knobs"][level]
        lines.append(
            f"| {level} | {knobs} | {row['samples']} | {row['in-process']:.2f} s | "
            f"{row['process']:.2f} s | {row['lowest_ft']:.1f} ft at {row['lowest_at_s']:.2f} s |"
        )
    lines += [
        "",
        "ARCH-COMP's instance (from 4040 ft), each level searched alone:",
        "",
        "| level | simulations | violation | lowest robustness | at | wall time |",
        "|---|---|---|---|---|---|",
    ]
    for level, row in data["arch"].items():
        found = "none" if row["first_violation"] is None else f"at {row['first_violation']}"
        lines.append(
            f"| {level} | {row['simulations']} | {found} | {row['lowest_robustness_ft']:.1f} ft "
            f"| {_fmt_sample(row['lowest_sample'])} | {row['wall_s']:.0f} s |"
        )
    low = data["lowered"]
    seeds = len(low["multi"])
    lines += [
        "",
        f"The instance from {LOWERED:g} ft, {seeds} seeds: each level alone (median simulations "
        "to the first violation / share of searches that found one), then searched at low and "
        "confirmed at medium and high (totals over the seeds: violations from below re-run at "
        "a level / held there):",
        "",
        "| search | simulations to a violation | found | median wall time |",
        "|---|---|---|---|",
    ]
    for level, row in low["alone"].items():
        lines.append(
            f"| {level} alone | {row['median']:g} | {row['found']}/{row['searches']} | "
            f"{row['wall_median_s']:.1f} s |"
        )
    multi = low["multi"]
    confirmed = [r["first_confirmed"] for r in multi if r["found"]]
    per_level = {
        name: (
            sum(r["levels"][name]["tried"] for r in multi),
            sum(r["levels"][name]["transferred"] for r in multi),
        )
        for name in ("medium", "high")
    }
    transfers = "; ".join(f"{n} {t}/{k}" for n, (k, t) in per_level.items())
    median_confirmed = f"{statistics.median(confirmed):g}" if confirmed else "none"
    wall = statistics.median(r["wall_s"] for r in multi)
    lines.append(
        f"| low, confirmed at medium and high | {median_confirmed} at low ({transfers}) | "
        f"{len(confirmed)}/{seeds} | {wall:.1f} s |"
    )
    lines.append(END)
    return "\n".join(lines)


def _aerobench(given: str | None) -> AeroBench:
    named = given or os.environ.get("MCS_AEROBENCH_DIR")
    return AeroBench(named or ROOT.parent / "shared" / "aerobench")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--aerobench", default=None, help="AeroBench's directory")
    parser.add_argument("--seeds", type=int, default=5, help="seeds of the lowered instance")
    parser.add_argument("--budget", type=int, default=arch.BUDGET)
    parser.add_argument("--optimizer", default=None, help="default: falsify's default")
    parser.add_argument("--repeats", type=int, default=3, help="flights timed per level")
    parser.add_argument(
        "--placement", default="in-process", help="where the searches fly (same bits anywhere)"
    )
    parser.add_argument("--quick", action="store_true", help="budget 30, 1 seed, 1 repeat")
    parser.add_argument("--docs", action="store_true", help="rewrite the figures in docs/")
    parser.add_argument("--from-results", action="store_true", help="only rewrite the figures")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.from_results:
        replace_section(PAGE, START, END, table(json.loads((RESULTS / "f16.json").read_text())))
        return 0
    if args.quick:
        args.budget, args.seeds, args.repeats = 30, 1, 1
    try:
        aerobench = _aerobench(args.aerobench)
    except ConfigurationError as exc:
        if args.aerobench or os.environ.get("MCS_AEROBENCH_DIR"):
            raise  # named on purpose: a wrong directory is an error
        # Where AeroBench is not to be had (it is not ours to ship), there is nothing to run.
        print(f"no AeroBench: nothing measured ({exc})")
        write_result("f16", {"skipped": str(exc)}, args.output)
        return 0
    optimizer = args.optimizer or default_optimizer()
    print("one flight per level", flush=True)
    data: dict[str, Any] = {
        "optimizer": optimizer,
        "budget": args.budget,
        "placement": args.placement,
        "knobs": {
            level: f"`{k.model}`, `{k.integrator}`, 1/{round(1 / k.step)} s"
            for level, k in FIDELITY_KNOBS.items()
        },
        "flights": flights(aerobench, args.repeats),
    }
    print(f"ARCH-COMP's instance, budget {args.budget}", flush=True)
    data["arch"] = arch_instance(aerobench, args.budget, optimizer, args.placement)
    print(f"from {LOWERED:g} ft, {args.seeds} seeds", flush=True)
    data["lowered"] = lowered(aerobench, args.budget, optimizer, args.seeds, args.placement)
    path = write_result("f16", data, args.output)
    data = json.loads(path.read_text())
    text = table(data)
    print(text)
    if args.docs and not args.quick:
        replace_section(PAGE, START, END, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
