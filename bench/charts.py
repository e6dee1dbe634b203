"""The benchmarks page's charts, drawn from the results with matplotlib (SVG, no timestamp).

Each chart is a file of ``docs/assets/pictures/`` that the generated section shows; a chart
whose results are missing is left out.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from _common import ROOT

PICTURES = ROOT / "docs" / "assets" / "pictures"
LEVELS = ("low", "medium", "high")


def _save(fig: Any, name: str) -> str:
    import matplotlib

    matplotlib.rcParams["svg.hashsalt"] = "multicosim"  # the same ids on every run
    PICTURES.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(PICTURES / name, format="svg", metadata={"Date": None})
    return name


def speed(results: dict[str, Any]) -> tuple[str, str] | None:
    """Real-time factor of the 60 s missions at each fidelity, rover and PX4 side by side."""
    from matplotlib.figure import Figure

    scenarios = [s for s in ("rover", "px4") if "levels" in results.get(s, {})]
    if not scenarios:
        return None
    fig = Figure(figsize=(7, 3.2))
    ax = fig.subplots()
    width = 0.8 / len(scenarios)
    for k, scenario in enumerate(scenarios):
        levels = results[scenario]["levels"]
        factors = [levels[level]["speed_factor"] for level in LEVELS]
        xs = [i + (k - (len(scenarios) - 1) / 2) * width for i in range(len(LEVELS))]
        bars = ax.bar(xs, factors, width, label="PX4" if scenario == "px4" else scenario)
        ax.bar_label(bars, labels=[f"{f:.0f}x" for f in factors], fontsize=8)
        for x, level in zip(xs, LEVELS, strict=True):
            target = levels[level].get("target")
            if target:
                ax.plot([x - width / 2, x + width / 2], [target, target], color="black", lw=1)
    ax.set_yscale("log")
    ax.set_xticks(
        range(len(LEVELS)),
        [f"{lv}\n({results[scenarios[0]]['levels'][lv]['placement']})" for lv in LEVELS],
    )
    ax.set_ylabel("times real time (log)")
    ax.set_title("60 s mission: speed at each fidelity (black: the target)")
    ax.legend(fontsize=8)
    return _save(fig, "bench-speed.svg"), "Speed of a 60 s mission at each fidelity, rover and PX4"


def fleet(results: dict[str, Any]) -> tuple[str, str] | None:
    """A fleet's wall time per simulated second against its number of vehicles."""
    from matplotlib.figure import Figure

    data = results.get("fleet")
    if not data or "growth" not in data:
        return None
    fig = Figure(figsize=(7, 3.2))
    ax = fig.subplots()
    for level, g in data["growth"].items():
        ns = [p["vehicles"] for p in g["points"]]
        ax.plot(ns, [1e3 * p["per_sim_s"] for p in g["points"]], "o-", label=f"built-in, {level}")
    real = data.get("real", {}).get("points", [])
    if real:
        ax.plot(
            [p["vehicles"] for p in real],
            [1e3 * p["wall_s"] / p["sim_s"] for p in real],
            "s-",
            label="real PX4, medium",
        )
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("vehicles in one world")
    ax.set_ylabel("wall ms per simulated s (log)")
    ax.set_title("Several vehicles: cost against their number")
    ax.legend(fontsize=8)
    return _save(fig, "bench-fleet.svg"), "A fleet's cost against its number of vehicles"


CHARTS: tuple[Callable[[dict[str, Any]], tuple[str, str] | None], ...] = (speed, fleet)


def charts(summary: dict[str, Any]) -> list[tuple[str, str]]:
    """Draw every chart the results allow; each one's file name and caption."""
    drawn = (chart(summary["results"]) for chart in CHARTS)
    return [c for c in drawn if c is not None]
