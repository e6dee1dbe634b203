"""A trace as a picture: the paths (plan, estimate, truth), the requirement's signals, its margin.

The path panel draws east to the right and north up, from the ``mcs/path/*`` channels
scenarios derive (each labelled by what it is: ``truth``, ``estimate``, ...) and the plan
(``mcs/plan``); a fleet's, each vehicle's in a colour of its own (``mcs/path/<vehicle>/*``,
``mcs/plan/<vehicle>``), with each pair's closest approach (``mcs/encounter/<a>/<b>``)
marked between the two. The signal panel plots the signals the requirement reads; the robustness
panel the deciding predicate's margin. Both mark the first violation and the worst time,
and shade the window of each attack an injector ran (``mcs/attack``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.deps import require
from ..core.errors import TraceError
from ..core.files import replacing
from ._convert import (
    ATTACK_CHANNEL,
    ENCOUNTER_CHANNEL,
    OBSTACLES_CHANNEL,
    PATH_CHANNEL,
    PLAN_CHANNEL,
    ROBUSTNESS_CHANNEL,
    TRAJECTORY_CHANNEL,
)
from ._mcap import METADATA_NAME, TraceData, TraceMessage, read_trace

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["figure", "plot_trace"]

_STYLES = {
    "truth": ("tab:green", "-"),
    "measured": ("tab:green", "-"),
    "estimate": ("tab:blue", "-"),
    "sensed": ("tab:blue", "-"),
}
# A fleet's vehicles, one colour each (truth and estimate alike), in the order first drawn.
_FLEET_COLORS = ("tab:blue", "tab:green", "tab:purple", "tab:olive", "tab:cyan", "tab:pink")
_DESCRIPTIONS = {
    "truth": "truth (the world's position)",
    "measured": "measured (the world's position sensor)",
    "estimate": "estimate (what the vehicle believed)",
    "sensed": "sensed (what the controller read)",
}


def _vehicles(paths: Sequence[str]) -> list[str]:
    """The fleet's vehicles whose paths are drawn (``mcs/path/<vehicle>/<kind>``), in order."""
    found: list[str] = []
    for topic in paths:
        label = topic.removeprefix(PATH_CHANNEL + "/")
        vehicle = label.rpartition("/")[0]
        if vehicle and vehicle not in found:
            found.append(vehicle)
    return found


def _vehicle_color(vehicle: str, vehicles: Sequence[str]) -> str:
    return (
        _FLEET_COLORS[vehicles.index(vehicle) % len(_FLEET_COLORS)]
        if vehicle in vehicles
        else "tab:gray"
    )


def _path_style(label: str, vehicles: Sequence[str]) -> tuple[str | None, str, str]:
    """A path's colour, line style and legend: one vehicle's by what it is; a fleet's by the
    vehicle (its colour) and what it is (truth solid, estimate dashed)."""
    vehicle, _, kind = label.rpartition("/")
    if not vehicle:
        color, style = _STYLES.get(label, (None, "-"))
        return color, style, _DESCRIPTIONS.get(label, label)
    style = "--" if kind in ("estimate", "sensed") else "-"
    return _vehicle_color(vehicle, vehicles), style, f"{vehicle}: {kind}"


def _approaches(ax: Axes, data: TraceData) -> None:
    """Mark each pair's closest approach (``mcs/encounter/<a>/<b>``): a line between the two
    vehicles' true positions then, labelled with the separation and the time."""
    for topic in sorted(t for t in data.channels if t.startswith(ENCOUNTER_CHANNEL + "/")):
        a, _, b = topic.removeprefix(ENCOUNTER_CHANNEL + "/").partition("/")
        samples = _columns(data.topic(topic), "separation")
        if not samples["time"]:
            continue
        k = min(range(len(samples["time"])), key=lambda i: samples["separation"][i])
        when, separation = samples["time"][k], samples["separation"][k]
        ends = []
        for vehicle in (a, b):
            cols = _columns(data.topic(f"{PATH_CHANNEL}/{vehicle}/truth"), "east", "north")
            if not cols["time"]:
                break
            i = min(range(len(cols["time"])), key=lambda j: abs(cols["time"][j] - when))
            ends.append((cols["east"][i], cols["north"][i]))
        if len(ends) != 2:
            continue
        (line,) = ax.plot(
            [e for e, _ in ends],
            [n for _, n in ends],
            "s-",
            color="black",
            markersize=5,
            linewidth=1.0,
            label=f"closest {a}-{b}: {separation:.1f} m at {when:.1f} s",
        )
        line.set_gid(f"approach/{a}/{b}")


def _separations(ax: Axes, data: TraceData) -> bool:
    """Each pair's separation and horizontal separation over time (a fleet's run without a
    requirement); whether there was a pair to draw."""
    drawn = False
    for topic in sorted(t for t in data.channels if t.startswith(ENCOUNTER_CHANNEL + "/")):
        pair = topic.removeprefix(ENCOUNTER_CHANNEL + "/").replace("/", "-")
        cols = _columns(data.topic(topic), "separation", "horizontal")
        if not cols["time"]:
            continue
        (line,) = ax.plot(cols["time"], cols["separation"], label=f"{pair}: separation")
        line.set_gid(f"separation/{pair}")
        ax.plot(
            cols["time"],
            cols["horizontal"],
            linestyle="--",
            color=line.get_color(),
            label=f"{pair}: horizontal",
        )
        drawn = True
    if drawn:
        ax.set_title("separation between the vehicles (no requirement evaluated)")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("m")
        ax.legend(loc="best", fontsize=8)
    return drawn


def _columns(messages: Sequence[TraceMessage], *names: str) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {"time": [], **{n: [] for n in names}}
    for m in messages:
        if not isinstance(m.data, dict) or not all(
            isinstance(m.data.get(n), int | float) for n in names
        ):
            continue
        out["time"].append(m.time)
        for n in names:
            out[n].append(float(m.data[n]))
    return out


def _float(text: str | None) -> float | None:
    try:
        value = float(text) if text is not None and text not in ("", "null") else None
    except ValueError:
        return None
    return value if value is not None and math.isfinite(value) else None


def _text(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.4g}"


def _mark(ax: Axes, first: float | None, worst: float | None) -> None:
    if first is not None:
        ax.axvline(first, color="tab:red", linewidth=1.2, label=f"first violation ({first:.3g} s)")
    if worst is not None:
        ax.axvline(worst, color="tab:red", linestyle=":", label=f"worst time ({worst:.3g} s)")


def _attacks(ax: Axes, windows: list[TraceMessage], until: float | None) -> None:
    """Shade each attack's window (an injector's models, ``mcs/attack``)."""
    for message in windows:
        w = message.data
        if not isinstance(w, dict) or _float(w.get("start")) is None:
            continue
        start = float(w["start"])
        end = _float(w.get("end"))
        end = end if end is not None else max(until or start, start)
        label = f"attack: {w.get('model')} on {w.get('sensor')}"
        gid = f"attack/{w.get('sensor')}/{w.get('model')}"
        if end > start:
            ax.axvspan(start, end, color="tab:orange", alpha=0.15, label=label).set_gid(gid)
        else:  # nothing after its start was recorded: mark where it begins
            ax.axvline(start, color="tab:orange", linewidth=1.0, label=label).set_gid(gid)


def figure(data: TraceData, title: str = "") -> Figure:
    """The plot of a trace read back (see the module docstring)."""
    require("matplotlib", "plot")
    from matplotlib.figure import Figure

    info = data.info
    paths = sorted(t for t in data.channels if t.startswith(PATH_CHANNEL + "/"))
    trajectory = data.topic(TRAJECTORY_CHANNEL)
    robustness = data.topic(ROBUSTNESS_CHANNEL)
    if not (paths or trajectory or robustness):
        raise TraceError(
            "the trace holds nothing to plot (no mcs/path/*, mcs/trajectory or mcs/robustness)"
        )
    first = _float(info.get("first_violation"))
    worst = _float(info.get("worst_time"))
    windows = data.topic(ATTACK_CHANNEL)
    ends = [m.time for m in (*trajectory, *robustness)]
    until = max(ends) if ends else None

    fig = Figure(figsize=(8, 12))
    ax_path, ax_signals, ax_rob = fig.subplots(3, 1, height_ratios=(3, 2, 2))
    verdict = ""
    rho = _float(info.get("robustness"))
    if info.get("requirement"):
        state = "violated" if rho is not None and rho < 0 else "holds"
        verdict = f"\n{info['requirement']}: {state} (robustness {_text(rho)})"
    fig.suptitle(f"{title or info.get('test') or 'trace'}{verdict}", fontsize=9)

    # -- paths: east right, north up --------------------------------------------------------
    if paths:
        vehicles = _vehicles(paths)
        for topic in paths:
            label = topic.removeprefix(PATH_CHANNEL + "/")
            color, style, description = _path_style(label, vehicles)
            cols = _columns(data.topic(topic), "east", "north")
            (line,) = ax_path.plot(
                cols["east"],
                cols["north"],
                style,
                color=color,
                label=description,
                linewidth=1.2,
            )
            line.set_gid(f"path/{label}")
            if first is not None and cols["time"]:
                i = min(range(len(cols["time"])), key=lambda k: abs(cols["time"][k] - first))
                ax_path.plot(cols["east"][i], cols["north"][i], "x", color="tab:red", markersize=9)
        plans = sorted(t for t in data.channels if t.startswith(PLAN_CHANNEL + "/"))
        for topic in (PLAN_CHANNEL, *plans):
            for m in data.topic(topic)[-1:]:
                points = m.data.get("points", []) if isinstance(m.data, dict) else []
                if not points:
                    continue
                vehicle = topic.removeprefix(PLAN_CHANNEL).lstrip("/")
                (line,) = ax_path.plot(
                    [p["east"] for p in points],
                    [p["north"] for p in points],
                    "o--",
                    color=_vehicle_color(vehicle, vehicles) if vehicle else "tab:orange",
                    alpha=0.6 if vehicle else 1.0,
                    label=f"{vehicle}: plan" if vehicle else "plan",
                    markersize=4,
                )
                line.set_gid(f"plan/{vehicle}" if vehicle else "plan")
        _approaches(ax_path, data)
        for m in data.topic(OBSTACLES_CHANNEL)[-1:]:
            shapes = m.data.get("obstacles", []) if isinstance(m.data, dict) else []
            for k, shape in enumerate(shapes):
                outline = shape.get("footprint", [])
                (patch,) = ax_path.fill(
                    [p["east"] for p in outline],
                    [p["north"] for p in outline],
                    color="tab:brown",
                    alpha=0.45,
                    label="obstacles" if k == 0 else None,
                )
                patch.set_gid(f"obstacle/{shape.get('name', k)}")
        if first is not None:
            ax_path.plot([], [], "x", color="tab:red", label="at the first violation")
        ax_path.set_xlabel("east (m)")
        ax_path.set_ylabel("north (m)")
        ax_path.set_aspect("equal", adjustable="datalim")
        ax_path.set_title("path (local frame, from the start)")
    elif trajectory:
        keys = [
            k
            for k in ("x", "y")
            if isinstance(trajectory[0].data, dict) and k in trajectory[0].data
        ]
        for key in keys:
            cols = _columns(trajectory, key)
            ax_path.plot(cols["time"], cols[key], label=key)
        ax_path.set_xlabel("time (s)")
        ax_path.set_title("position over time (no path recorded)")
    if ax_path.has_data():
        ax_path.legend(loc="best", fontsize=8)

    # -- the requirement's signals ----------------------------------------------------------
    signals = _names(info.get("signals"))
    if trajectory:
        fields = set(trajectory[0].data) if isinstance(trajectory[0].data, dict) else set()
        names = [s for s in signals if s in fields] or sorted(fields - {"time"})[:6]
        ax_signals.set_title(
            "signals of the requirement" if signals else "trajectory signals (no requirement)"
        )
        for name in names:
            cols = _columns(trajectory, name)
            (line,) = ax_signals.plot(cols["time"], cols[name], label=name)
            line.set_gid(f"signal/{name}")
    elif paths:
        ax_signals.set_title("height above the start (no requirement evaluated)")
        for topic in paths:
            cols = _columns(data.topic(topic), "up")
            ax_signals.plot(cols["time"], cols["up"], label=topic.removeprefix(PATH_CHANNEL + "/"))
    _mark(ax_signals, first, worst)
    _attacks(ax_signals, windows, until)
    if ax_signals.has_data():
        ax_signals.legend(loc="best", fontsize=8)
    ax_signals.set_xlabel("time (s)")

    # -- robustness -------------------------------------------------------------------------
    if robustness:
        cols = _columns(robustness, "margin")
        head = robustness[0].data
        ax_rob.plot(
            cols["time"],
            cols["margin"],
            color="tab:purple",
            drawstyle="steps-post",
            label=f"margin of {head.get('predicate') or head.get('formula')}",
        )
        ax_rob.axhline(0.0, color="black", linewidth=0.8)
        if rho is not None:
            ax_rob.axhline(rho, color="tab:red", linestyle="--", linewidth=0.8, label="robustness")
        _mark(ax_rob, first, worst)
        _attacks(ax_rob, windows, until)
        ax_rob.set_title(f"robustness of {head.get('formula')}: {_text(rho)}")
        ax_rob.legend(loc="best", fontsize=8)
        ax_rob.set_xlabel("time (s)")
    elif not _separations(ax_rob, data):
        ax_rob.set_axis_off()
        ax_rob.text(0.5, 0.5, "no requirement evaluated", ha="center", va="center")
    fig.tight_layout()
    return fig


def _names(text: str | None) -> list[str]:
    import json

    if not text:
        return []
    try:
        value = json.loads(text)
    except ValueError:
        return []
    return [str(v) for v in value] if isinstance(value, list) else []


def plot_trace(trace: str | Path, output: str | Path) -> Path:
    """Plot a multicosim trace to a PNG; raise TraceError for a file that is not one."""
    data = read_trace(trace)
    if METADATA_NAME not in data.metadata:
        raise TraceError(
            f"{str(trace)!r} is an MCAP file but not a multicosim trace (it has no "
            f"{METADATA_NAME!r} metadata record)"
        )
    fig = figure(data)
    output = Path(output)
    with replacing(output) as temporary:
        fig.savefig(temporary, dpi=80, format="png")
    return output
