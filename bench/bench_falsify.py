"""Robustness-guided vs unguided falsification: examples to the first violation.

The cart scenario of ``tests/falsify/falsify_cart.py`` (a cart must never come to rest in a
0.2 m pit; inputs: speed in [0, 5] m/s and 1..100 driving periods, so only about 1% of
inputs violate). For each seed of the same seed set, Hypothesis searches twice at low
fidelity with the same budget: once guided (``hypothesis.target(-robustness)``), once not.
Both searches draw the same examples until Hypothesis starts optimising the target (at half
the budget, for budgets under 1000), so the difference is what guidance adds.

Usage: ``python bench/bench_falsify.py [--seeds N] [--budget N] [--quick]``. Prints a table
and writes ``bench/results/falsify.json``. (Simulations per minute per fidelity level, and
``pytest -n 2`` against ``-n 0``, are in ``bench/bench_throughput.py``.)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from _common import ROOT, write_result

sys.path.insert(0, str(ROOT / "tests" / "falsify"))

from falsify_cart import PIT, run
from hypothesis import strategies as st

from multicosim.falsify import examples_to_first_violation, falsify

INPUTS = st.tuples(st.floats(0.0, 5.0), st.integers(1, 100))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30, help="seeds 0..N-1 (default 30)")
    parser.add_argument("--budget", type=int, default=300, help="examples per search")
    parser.add_argument("--quick", action="store_true", help="8 seeds")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    if args.quick:
        args.seeds = 8

    rows: dict[str, list[dict[str, Any]]] = {"guided": [], "unguided": []}
    summaries: dict[str, Any] = {}
    for mode in ("guided", "unguided"):
        results = []
        started = time.perf_counter()
        for seed in range(args.seeds):
            result = falsify(
                run,
                PIT,
                INPUTS,
                levels=("low",),
                budget=args.budget,
                seed=seed,
                guided=mode == "guided",
                shrink=False,
            )
            results.append(result)
            rows[mode].append(
                {
                    "seed": seed,
                    "first_violation": result.first_violation,
                    "examples": result.examples,
                }
            )
        wall = time.perf_counter() - started
        stats = examples_to_first_violation(results)
        simulations = sum(r.examples for r in results)
        summaries[mode] = {**stats, "wall_s": wall, "ms_per_simulation": 1e3 * wall / simulations}

    both = [
        (g["first_violation"], u["first_violation"])
        for g, u in zip(rows["guided"], rows["unguided"], strict=True)
    ]
    paired = {
        "guided_earlier": sum(1 for g, u in both if g is not None and (u is None or g < u)),
        "same": sum(1 for g, u in both if g == u),
        "unguided_earlier": sum(1 for g, u in both if u is not None and (g is None or u < g)),
    }
    report = {
        "scenario": {
            "requirement": PIT,
            "inputs": "speed in [0, 5], steps in 1..100",
            "fidelity": "low",
            "budget": args.budget,
            "seeds": args.seeds,
        },
        "summary": summaries,
        "paired": paired,
        "per_seed": rows,
    }
    out = write_result("falsify", report, args.output)

    print(f"{'':10}{'found':>8}{'median':>9}{'mean*':>9}{'ms/sim':>9}")
    for mode, s in summaries.items():
        median = f"{s['median_found']:.0f}" if s["median_found"] is not None else "-"
        print(
            f"{mode:10}{s['found']:>5}/{s['searches']:<2}{median:>9}"
            f"{s['mean_censored']:>9.1f}{s['ms_per_simulation']:>9.2f}"
        )
    print(f"paired by seed: {paired}")
    print("mean*: examples to the first violation, a search that found none counted as budget+1")
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
