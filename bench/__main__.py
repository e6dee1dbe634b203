"""Run every benchmark, print one table, write bench/results/all.json, update docs/benchmarks.md.

    python -m bench                  # the full run (about 6 minutes on 2 cores)
    python -m bench --quick          # a shorter run (about 1 minute)
    python -m bench --only rover,trace   # some benchmarks: table only
    python -m bench --only ardupilot --merge   # re-measure some, keep the others' figures
    python -m bench --smoke          # does every benchmark still run? (CI; writes nothing)

The falsification benchmark takes longer and keeps its own table on that page:
``python bench/bench_search.py --docs``; so does the F-16's (ARCH-COMP "F16", on the how-to
page of the F-16): ``python bench/bench_f16.py --docs``.

Each benchmark runs as its own process (``bench/bench_NAME.py``, which writes
``bench/results/NAME.json``), one after the other, so that none inherits another's heap,
sockets or children. The summary rows are built from those files; the benchmarks page's
section (between ``<!-- bench:start -->`` and ``<!-- bench:end -->``) is regenerated from
``all.json`` and nothing else on the page is touched.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _common import BENCHMARKS_PAGE, RESULTS, ROOT, machine, replace_section  # noqa: E402
from charts import charts  # noqa: E402

START, END = "<!-- bench:start -->", "<!-- bench:end -->"
# Run order: the cheap, noise-sensitive ones first.
BENCHMARKS = (
    "transport",
    "fmi",
    "trace",
    "rover",
    "px4",
    "px4_low",
    "surroundings",
    "sitl",
    "hold",
    "ardupilot",
    "docker",
    "throughput",
    "scaling",
    "fleet",
    "campaign",
)

Row = dict[str, Any]


# What the smoke run (--smoke) gives the falsification benchmark: one seed of each search,
# multi-fidelity on one rover and one PX4 problem with a small budget, no real PX4: enough
# to run every path of it.
SEARCH_SMOKE = (
    "--seeds", "1", "--rate-samples", "20", "--real-seeds", "0",
    "--mf-seeds", "1", "--mf-budget", "10", "--mf-problems", "rover-lane,px4-altitude",
)  # fmt: skip
# ... and the F-16 benchmark: five simulations per search, one seed, one timed flight.
F16_SMOKE = ("--budget", "5", "--seeds", "1", "--repeats", "1")


def run_benchmark(
    name: str, quick: bool, results: Path = RESULTS, extra: tuple[str, ...] = ()
) -> dict[str, Any]:
    """Run ``bench_NAME.py`` in its own process; its results, or why there are none."""
    out = results / f"{name}.json"
    cmd = [sys.executable, str(HERE / f"bench_{name}.py"), "--output", str(out), *extra]
    if quick:
        cmd.append("--quick")
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    elapsed = time.perf_counter() - t0
    if done.returncode != 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-3:]
        return {"error": " / ".join(tail) or f"exit code {done.returncode}", "elapsed_s": elapsed}
    data: dict[str, Any] = json.loads(out.read_text())
    data["elapsed_s"] = elapsed
    return data


# -- summary rows: one per figure, with its target and verdict --------------------------------


def row(
    group: str,
    what: str,
    value: str,
    *,
    ratio: float | None = None,
    unit: str = "",
    target: str = "",
    met: bool | None = None,
    limit: str = "",
) -> Row:
    """One line of the summary table."""
    return {
        "group": group,
        "what": what,
        "value": value,
        "ratio": ratio,
        "unit": unit,
        "target": target,
        "status": "-" if met is None else ("met" if met else "not met"),
        "limit": limit,
    }


def px4_low_rows(data: dict[str, Any]) -> list[Row]:
    """The 4-waypoint mission at low fidelity, messages passed in-process or parsed."""
    target = data["target"]
    rows = []
    for way, note in (
        ("messages", "the in-process ground station takes the downlink's messages"),
        ("frames", "the ground station parses every frame, as a peer in another process"),
    ):
        r = data["ways"][way]
        met = r["speed_factor"] >= target if way == "messages" else None
        if met is False:
            host = data["machine"]
            note += f" (measured at load average {host['load_average']:g} on {host['cores']} cores)"
        rows.append(
            row(
                "speed (4-waypoint mission)",
                f"PX4 low, {way}",
                f"{r['speed_factor']:.0f}x real time",
                ratio=r["speed_factor"],
                unit="x",
                target=f">= {target:g}x" if way == "messages" else "",
                met=met,
                limit=note,
            )
        )
    return rows


def overhead_row(group: str, what: str, value: str, pct: float, target: float, limit: str) -> Row:
    """A row of what something adds, in per cent, against its target; ``limit`` if missed."""
    met = pct <= target
    return row(
        group,
        what,
        value,
        ratio=1 + pct / 100,
        target=f"<= +{target:g} %",
        met=met,
        limit="" if met else limit,
    )


def surroundings_rows(data: dict[str, Any]) -> list[Row]:
    """What obstacles and wind add to a 60 s PX4 mission's CPU time, at low and medium."""
    return [
        overhead_row(
            "obstacles and wind (60 s PX4 mission)",
            f"PX4 {level}, {data['obstacles']} obstacles + steady wind, light turbulence / "
            "none: CPU per simulated second (per run)",
            f"{r['per_second_percent']:+.1f} % ({r['per_run_percent']:+.1f} % per run; "
            f"{r['cpu_s']['busy'] * 1e3:.0f} / {r['cpu_s']['plain'] * 1e3:.0f} ms CPU for "
            f"{r['sim_s']['busy']:.1f} / {r['sim_s']['plain']:.1f} s)",
            r["per_second_percent"],
            r["target_percent"],
            "the clearances to the obstacles and the wind's drag and turbulence are worked "
            "out every world period"
            + ("" if level == "low" else ", and MuJoCo looks for collisions every step"),
        )
        for level, r in data["levels"].items()
    ]


def speed_rows(data: dict[str, Any], scenario: str) -> list[Row]:
    rows = []
    levels = data["levels"]
    for level in ("low", "medium", "high"):
        r = levels[level]
        target = r["target"]
        placement = r["placement"]
        note = ""
        if level == "high" and r.get("fallback_reason"):
            note = f"ran as local processes: {r['fallback_reason']}"
        if level == "low":
            limit = "Python model and controller code in one process"
        else:
            over = r.get("over_raw_one_call", r.get("over_raw"))
            limit = (
                f"{over:.1f}x the raw MuJoCo time of its model; the rest is lockstep round "
                "trips between processes" + (" and containers" if placement == "docker" else "")
            )
        rows.append(
            row(
                "speed (60 s mission)",
                f"{scenario} {level} ({placement})",
                f"{r['speed_factor']:.0f}x real time",
                ratio=r["speed_factor"],
                unit="x",
                target=f">= {target:g}x",
                met=r["speed_factor"] >= target,
                limit="; ".join(x for x in (limit, note) if x),
            )
        )
    return rows


def physics_rows(rover: dict[str, Any] | None, px4: dict[str, Any] | None) -> list[Row]:
    rows = []
    if rover is not None:
        for level in ("low", "medium", "high"):
            r = rover["levels"][level]
            rows.append(
                row(
                    "distance to raw MuJoCo",
                    f"rover {level} wall / raw mj_step ({r['raw_mujoco_model']} model)",
                    f"{r['over_raw_one_call']:.2f}x (per-period batches: "
                    f"{r['over_raw_per_period']:.2f}x)",
                    ratio=r["over_raw_one_call"],
                )
            )
    if px4 is not None:
        for level in ("low", "medium", "medium_in_process", "high"):
            r = px4["levels"][level]
            rows.append(
                row(
                    "distance to raw MuJoCo",
                    f"PX4 {level.replace('_', ' ')} wall / raw mj_step ({r['raw_mujoco_model']})",
                    f"{r['over_raw']:.2f}x",
                    ratio=r["over_raw"],
                )
            )
    return rows


def transport_rows(data: dict[str, Any]) -> list[Row]:
    rows = []
    target = data["target_ratio"]
    for r in data["send"]:
        s = r["stats"]
        met = r["ratio"] <= target and r["ratio_p10"] <= target
        rows.append(
            row(
                "transport (process)",
                f"send, {r['payload_floats']} floats / raw REQ-REP",
                f"{s['send']['median_us']:.0f} us / {s['raw REQ/REP']['median_us']:.0f} us",
                ratio=r["ratio"],
                target=f"<= {target:g} (median and p10)",
                met=met,
                limit=""
                if met
                else f"median ratio {r['ratio']:.2f}, p10 ratio {r['ratio_p10']:.2f} "
                f"({s['send']['p10_us']:.0f} us vs {s['raw REQ/REP']['p10_us']:.0f} us): "
                "the raw pair's fastest calls are those where both processes stay on a core; "
                "send adds about 20 us of Python on the two sides (frame encoding, the "
                "firmware's per-call context and validation), which the p10 exposes",
            )
        )
    st = data["step"]
    s = st["stats"]
    rows.append(
        row(
            "transport (process)",
            "lockstep exchange / raw ROUTER-DEALER",
            f"{s['advance(period)']['median_us']:.0f} us / "
            f"{s['raw ROUTER/DEALER']['median_us']:.0f} us",
            ratio=st["ratio"],
        )
    )
    if "ratio_curve" in st:
        rows.append(
            row(
                "transport (process)",
                "raw ROUTER-DEALER over CURVE / plain (the per-run token costs no crypto)",
                f"{s['raw ROUTER/DEALER, CURVE']['median_us']:.0f} us / "
                f"{s['raw ROUTER/DEALER']['median_us']:.0f} us",
                ratio=st["ratio_curve"],
            )
        )
    rows.append(
        row(
            "transport (process)",
            "lockstep exchange / raw pymavlink UDP round trip",
            f"{s['advance(period)']['median_us']:.0f} us / "
            f"{s['raw pymavlink UDP']['median_us']:.0f} us",
            ratio=st["ratio_vs_mavlink"],
            limit="ZeroMQ over TCP passes each frame through I/O threads; bare UDP does not",
        )
    )
    ip = data["in_process"]["stats"]
    for case in ("in-process send", "in-process step"):
        rows.append(
            row(
                "transport (in-process)",
                f"{case} / direct call of the handler",
                f"{ip[case]['median_us']:.1f} us / {ip['direct call']['median_us']:.2f} us",
                ratio=ip[case]["median_us"] / ip["direct call"]["median_us"],
            )
        )
    return rows


def docker_rows(data: dict[str, Any]) -> list[Row]:
    if "skipped" in data:
        return [
            row("container", "container lifecycle and round trip", "skipped", limit=data["skipped"])
        ]
    med, ratios, targets = data["median"], data["ratios"], data["targets"]
    start, rtt = med["start_ready_s"], med["round_trip_s"]
    r_start = ratios["component_start_vs_raw"]
    r_send = ratios["send_vs_raw_zmq"]
    return [
        row(
            "container",
            "start-to-ready: ContainerFirmwareComponent / raw docker run + first reply",
            f"{start['component'] * 1e3:.0f} ms / {start['raw'] * 1e3:.0f} ms",
            ratio=r_start,
            target=f"<= {targets['component_start_vs_raw']:g}",
            met=r_start <= targets["component_start_vs_raw"],
            limit=""
            if r_start <= targets["component_start_vs_raw"]
            else f"{(start['component'] - start['raw']) * 1e3:.0f} ms over the raw start: "
            "the firmware's handshake through the lockstep coordinator and reading the "
            "published port back from the engine",
        ),
        row(
            "container",
            "start-to-ready: ContainerSimulator.start (+ network) / raw",
            f"{start['simulation'] * 1e3:.0f} ms / {start['raw'] * 1e3:.0f} ms",
            ratio=ratios["simulation_start_vs_raw"],
        ),
        row(
            "container",
            "stop: node.stop() / raw docker stop + remove",
            f"{start['component_stop'] * 1e3:.0f} ms / {start['raw_stop'] * 1e3:.0f} ms",
            ratio=ratios["component_stop_vs_raw"],
        ),
        row(
            "container",
            "send through the published port / raw pyzmq",
            f"{rtt['send'] * 1e6:.0f} us / {rtt['raw'] * 1e6:.0f} us",
            ratio=r_send,
            target=f"<= {targets['send_vs_raw_zmq']:g}",
            met=r_send <= targets["send_vs_raw_zmq"],
        ),
    ]


def trace_rows(data: dict[str, Any]) -> list[Row]:
    pct = data["overhead_percent"]
    target = data["target_percent"]
    return [
        overhead_row(
            "trace recording",
            f"rover low, 60 s: recording on / off ({data['messages_recorded']} messages)",
            f"{data['cpu_s']['recorded_median'] * 1e3:.1f} ms / "
            f"{data['cpu_s']['plain_median'] * 1e3:.1f} ms CPU",
            pct,
            target,
            "the recorder keeps every message alive (allocation and "
            "collector work grow with the run)",
        ),
        row(
            "trace recording",
            "saving the MCAP trace (failing tests only)",
            f"{data['save']['seconds'] * 1e3:.0f} ms, "
            f"{data['save']['messages_per_s'] / 1e3:.0f}k messages/s",
        ),
    ]


def throughput_rows(data: dict[str, Any]) -> list[Row]:
    rows = []
    for level, r in data["levels"].items():
        note = r.get("fallback_reason") or ""
        rows.append(
            row(
                "falsification throughput",
                f"rover 60 s, {level} ({r['placement']}), fresh simulation each",
                f"{r['per_minute']:.0f} simulations/min",
                ratio=r["per_minute"],
                unit="/min",
                limit=f"ran as local processes: {note}" if note else "",
            )
        )
    p = data["pytest"]
    rows.append(
        row(
            "falsification throughput",
            f"pytest -n 2 / -n 0, {p['n0']['tests']} medium simulation tests ({p['cores']} cores)",
            f"{p['n2']['wall_s']:.1f} s vs {p['n0']['wall_s']:.1f} s: speedup {p['speedup']:.2f}",
            ratio=p["speedup"],
            limit="each medium test already runs two component processes beside pytest, "
            "so two workers share two cores with four busy processes",
        )
    )
    return rows


def scaling_rows(data: dict[str, Any]) -> list[Row]:
    rows = []
    linear = 1.1  # an exponent up to this counts as linear growth
    for level, e in data["length"].items():
        exp = e["time_exponent"]
        rows.append(
            row(
                "cost growth",
                f"wall time vs mission length 30-240 s, {level}",
                f"exponent {exp:.2f}",
                ratio=exp,
                target=f"linear (<= {linear})",
                met=exp <= linear,
            )
        )
        if "memory_exponent" in e:
            first, last = e["points"][0], e["points"][-1]
            exp = e["memory_exponent"]
            rows.append(
                row(
                    "cost growth",
                    f"peak Python heap vs mission length, {level}",
                    f"exponent {exp:.2f} ({first['peak_bytes'] / 1e6:.2f} -> "
                    f"{last['peak_bytes'] / 1e6:.2f} MB)",
                    ratio=exp,
                    target=f"linear (<= {linear})",
                    met=exp <= linear,
                    limit="the trajectory the controller returns grows with the mission",
                )
            )
    for level, e in data["components"].items():
        exp = e["time_exponent"]
        per = e["per_component_s"]
        met = exp <= linear
        rows.append(
            row(
                "cost growth",
                f"added wall time vs 1-8 relays, {level}",
                f"exponent {exp:.2f} ({per * 1e3:.1f} ms per relay per 60 s mission)",
                ratio=exp,
                target=f"linear (<= {linear})",
                met=met,
                limit=""
                if met
                else "each relay is one more process on the same 2 cores: "
                "context switches grow with the number of runnable processes",
            )
        )
        if level == "low" and e["points"][0].get("peak_bytes"):
            first, last = e["points"][0], e["points"][-1]
            rows.append(
                row(
                    "cost growth",
                    "peak Python heap, 0 vs 8 relays, low",
                    f"{first['peak_bytes'] / 1e6:.2f} -> {last['peak_bytes'] / 1e6:.2f} MB",
                )
            )
    return rows


def fleet_rows(data: dict[str, Any]) -> list[Row]:
    """Cost against the number of vehicles; one vehicle with and without the fleet."""
    rows = []
    linear = 1.1
    for level, g in data["growth"].items():
        first, last = g["points"][0], g["points"][-1]
        exp = g["exponent"]
        span = f"{first['vehicles']}-{last['vehicles']}"
        detail = (
            f"exponent {exp:.2f}; {g['per_vehicle'] * 1e3:.1f} ms per vehicle per simulated s "
            f"({first['speed_factor']:.0f}x -> {last['speed_factor']:.1f}x real time)"
        )
        rows.append(
            row(
                "fleet (30 m leg each, at once)",
                f"wall time vs {span} built-in vehicles, {level}",
                detail,
                ratio=exp,
                target=f"linear (<= {linear})" if level == "low" else "",
                met=exp <= linear if level == "low" else None,
                limit=(
                    "the encounter monitor measures every pair each period in Python, "
                    f"n(n-1)/2 of them ({last['vehicles'] * (last['vehicles'] - 1) // 2} at "
                    f"{last['vehicles']} vehicles), and publishes each pair's sample"
                    if exp > linear
                    else ""
                )
                if level == "low"
                else "each vehicle's autopilot is a process of its own and the world steps "
                "every body: past 2 vehicles the 2 cores are shared by more runnable processes",
            )
        )
    for p in data["real"].get("points", []):
        rows.append(
            row(
                "fleet (30 m leg each, at once)",
                f"{p['vehicles']} real PX4 instance(s) in one medium world",
                f"{p['speed_factor']:.1f}x real time",
                ratio=p["speed_factor"],
                unit="x",
            )
        )
    for level, o in data["one_vehicle"].items():
        per = o["per_sim_s"]
        rows.append(
            row(
                "fleet (30 m leg each, at once)",
                f"one vehicle, {level}: fleet of one / px4.PX4 (wall per simulated s)",
                f"{o['ratio']:.2f} ({per['fleet of one'] * 1e3:.1f} / "
                f"{per['px4.PX4'] * 1e3:.1f} ms)",
                ratio=o["ratio"],
                target="<= 1.10 (within noise)",
                met=o["ratio"] <= 1.10,
            )
        )
    return rows


BUILDERS: dict[str, Callable[[dict[str, dict[str, Any]]], list[Row]]] = {
    "rover": lambda r: speed_rows(r["rover"], "rover"),
    "px4": lambda r: speed_rows(r["px4"], "PX4"),
    "px4_low": lambda r: px4_low_rows(r["px4_low"]),
    "surroundings": lambda r: surroundings_rows(r["surroundings"]),
    "sitl": lambda r: sitl_rows(r["sitl"]),
    "hold": lambda r: hold_rows(r["hold"]),
    "ardupilot": lambda r: ardupilot_rows(r["ardupilot"]),
    "physics": lambda r: physics_rows(r.get("rover"), r.get("px4")),
    "transport": lambda r: transport_rows(r["transport"]),
    "docker": lambda r: docker_rows(r["docker"]),
    "trace": lambda r: trace_rows(r["trace"]),
    "throughput": lambda r: throughput_rows(r["throughput"]),
    "scaling": lambda r: scaling_rows(r["scaling"]),
    "fleet": lambda r: fleet_rows(r["fleet"]),
    "campaign": lambda r: campaign_rows(r["campaign"]),
    "fmi": lambda r: fmi_rows(r["fmi"]),
}


def fmi_rows(data: dict[str, Any]) -> list[Row]:
    """FMUs as components: in-process against FMPy's own loop, as a process, growth."""
    group = "FMU components"
    if "skipped" in data:
        return [row(group, "FMU components", "skipped", limit=data["skipped"])]
    target = data["target_ratio"]
    rows = []
    for r in data["in_process"]:
        us = r["per_step_us"]
        met = r["ratio"] <= target
        rows.append(
            row(
                group,
                f"per step (CPU), in-process / FMPy's own co-simulation loop ({r['fmu']}, 10 ms)",
                f"{us['multicosim']:.1f} us / {us['fmpy']:.1f} us",
                ratio=r["ratio"],
                target=f"<= {target:g}",
                met=met,
                limit=""
                if met
                else "the lockstep scheduler's step, the record published every step and the "
                "topic routing come on top of the same FMI calls",
            )
        )
    p = data["process"]
    s = p["stats"]
    rows.append(
        row(
            group,
            f"per step, as a process / raw ROUTER-DEALER round trip ({p['fmu']})",
            f"{s['FMU as a process']['median_us']:.0f} us / "
            f"{s['raw ROUTER/DEALER']['median_us']:.0f} us",
            ratio=p["ratio"],
            limit=f"the lockstep exchange of a participant process that does nothing takes "
            f"{s['idle participant as a process']['median_us']:.0f} us here and the FMU's own "
            f"step {s['FMU in-process']['median_us']:.0f} us in-process",
        )
    )
    linear = 1.1
    for where, g in data["growth"].items():
        first, last = g["points"][0], g["points"][-1]
        met = g["exponent"] <= linear
        rows.append(
            row(
                group,
                f"{'CPU' if where == 'in-process' else 'wall'} time vs 1-16 FMUs in one "
                f"simulation, {where}",
                f"exponent {g['exponent']:.2f} ({first['per_fmu_step_us']:.1f} -> "
                f"{last['per_fmu_step_us']:.1f} us per FMU step)",
                ratio=g["exponent"],
                target=f"linear (<= {linear})",
                met=met,
                limit=""
                if met
                else (
                    "each FMU is one more process on the same 2 cores: context switches "
                    "grow with the number of runnable processes"
                    if where == "process"
                    else "the scheduler looks for the next member among all of them at every step"
                ),
            )
        )
    return rows


def sitl_rows(data: dict[str, Any]) -> list[Row]:
    """Real PX4 SITL: lockstep speed beside the built-in autopilot, and the transfer."""
    if "skipped" in data:
        return [row("real PX4", "real PX4 SITL in lockstep", "skipped", limit=data["skipped"])]
    real, builtin = data["speed"]["real PX4"], data["speed"]["built-in"]
    share = real["share"]
    met = real["speed_factor"] >= real["target"]
    rows = [
        row(
            "real PX4 (60 s mission)",
            "real PX4 SITL, medium (process, lockstep) / built-in medium",
            f"{real['speed_factor']:.1f}x / {builtin['speed_factor']:.1f}x real time",
            ratio=real["speed_factor"],
            unit="x",
            target=f">= {real['target']:g}x",
            met=met,
            limit=""
            if met
            else f"waiting for PX4's answers is {share['px4']:.0%} of the wall time: PX4's "
            "modules run on the same 2 cores as everything else",
        ),
        row(
            "real PX4 (60 s mission)",
            "where real PX4's wall time goes: PX4 / world / bridge and the rest",
            f"{share['px4']:.0%} / {share['world']:.0%} / {share['rest']:.0%}",
        ),
    ]
    transfer = data["transfer"]
    for level in ("low", "medium"):
        t = transfer[level]
        rows.append(
            row(
                "transfer to real PX4",
                f"built-in {level} vs real PX4, {t['missions']} missions: path distance",
                f"mean {t['mean_distance_m']:.2f} m, max {t['max_distance_m']:.2f} m; time "
                f"ratio {t['time_ratio_mean']:.2f}; same waypoints "
                f"{t['same_waypoints']}/{t['missions']}"
                + (
                    f"; same verdict {t['same_verdict']}/{t['missions']}"
                    if "same_verdict" in t
                    else ""
                ),
                ratio=t["mean_distance_m"],
                unit="m",
            )
        )
    if "real PX4" in transfer:
        rows.append(
            row(
                "transfer to real PX4",
                "attitude jitter in the noisy medium world (mean change of roll and pitch per "
                "50 ms sample): built-in medium / real PX4",
                f"{transfer['medium']['jitter_deg']:.2f} deg / "
                f"{transfer['real PX4']['jitter_deg']:.2f} deg",
            )
        )
    return rows


def hold_rows(data: dict[str, Any]) -> list[Row]:
    """Real PX4 holding a 10 m takeoff for 60 s in our world, before and after (bench_hold)."""

    def both(fmt: Any) -> str:
        before, after = data.get("before"), data["after"]
        return (fmt(before) + " -> " if before else "") + fmt(after)

    group = "real PX4 in our world (10 m takeoff, 60 s hold)"
    if "skipped" in data:
        return [row(group, "real PX4 holding in our world", "skipped", limit=data["skipped"])]
    rows = [
        row(
            group,
            "altitude PX4 estimates: mean (largest error); before -> after",
            both(lambda r: f"{r['altitude_mean_m']:.2f} m ({r['error_max_m']:.2f} m)"),
        ),
        row(
            group,
            "attitude jitter, std of roll / pitch; before -> after",
            both(lambda r: f"{r['roll_std_deg']:.3f} / {r['pitch_std_deg']:.3f} deg"),
        ),
    ]
    for name, label in (("hgt", "height"), ("pos", "position"), ("vel", "velocity")):
        rows.append(
            row(
                group,
                f"estimator {label} innovation test ratio, mean / max; before -> after",
                both(
                    lambda r, n=name: (
                        f"{r[f'{n}_test_ratio']['mean']:.3f} / {r[f'{n}_test_ratio']['max']:.3f}"
                    )
                ),
            )
        )
    return rows


def ardupilot_rows(data: dict[str, Any]) -> list[Row]:
    """Real ArduPilot SITL: lockstep speed, and one mission on three autopilots side by side."""
    if "skipped" in data:
        return [
            row("real ArduPilot", "ArduPilot SITL in lockstep", "skipped", limit=data["skipped"])
        ]
    rows: list[Row] = []
    for vehicle, name in (("copter", "ArduCopter"), ("rover", "ArduRover")):
        r = data["speed"][vehicle]
        share = r["share"]
        met = r["speed_factor"] >= r["target"]
        rows.append(
            row(
                "real ArduPilot (medium, process)",
                f"{name} mission, {r['sim_s']:.0f} s with its start-up",
                f"{r['speed_factor']:.1f}x real time; wall time: ArduPilot "
                f"{share['ardupilot']:.0%}, world {share['world']:.0%}, rest {share['rest']:.0%}",
                ratio=r["speed_factor"],
                unit="x",
                target=f">= {r['target']:g}x",
                met=met,
                limit=""
                if met
                else "one lockstep exchange per 2.5 ms frame (ArduPilot's loop rate), MuJoCo "
                "stepped and its state sent each frame, on the same 2 cores as everything else",
            )
        )
    side = data["side_by_side"]
    autopilots = side["autopilots"].items()
    flights = ", ".join(f"{n} {a['flight_s']:.0f} s" for n, a in autopilots)
    rows.append(row("same copter mission, three autopilots", "takeoff to landed (medium)", flights))
    if all("speed_factor" in a for _, a in autopilots):
        rows.append(
            row(
                "same copter mission, three autopilots",
                "speed, the same run (medium, process)",
                ", ".join(f"{n} {a['speed_factor']:.0f}x" for n, a in autopilots),
            )
        )
    for pair, d in side["paths"].items():
        rows.append(
            row(
                "same copter mission, three autopilots",
                f"true path distance, {pair}",
                f"mean {d['mean_distance_m']:.2f} m, max {d['max_distance_m']:.2f} m",
                ratio=d["mean_distance_m"],
                unit="m",
            )
        )
    return rows


def campaign_rows(data: dict[str, Any]) -> list[Row]:
    """Campaign throughput: process pool against Ray on the same machine."""
    n = data["samples"]
    rows = [
        row(
            "campaign",
            f"{n} rover missions (low), local process pool",
            f"{data['process']['per_minute']:.0f} simulations/min",
        )
    ]
    if data.get("ray"):
        rows.append(
            row(
                "campaign",
                f"{n} rover missions (low), Ray on this machine / process pool",
                f"{data['ray']['per_minute']:.0f} vs {data['process']['per_minute']:.0f} "
                "simulations/min",
                ratio=data["ray_vs_process_throughput"],
            )
        )
        rows.append(
            row(
                "campaign",
                "Ray per-task overhead / median simulation",
                f"{data['ray_task_overhead_ms']:.2f} ms / {data['simulation_ms_median']:.2f} ms",
                ratio=data["ray_overhead_vs_simulation"],
            )
        )
    return rows


def summarize(results: dict[str, dict[str, Any]]) -> list[Row]:
    """The summary rows of every benchmark that produced results."""
    ok = {name: data for name, data in results.items() if "error" not in data}
    rows: list[Row] = []
    for name, build in BUILDERS.items():
        needed = {"physics": "rover"}.get(name, name)
        if needed not in ok:
            if needed in results:
                rows.append(
                    row(name, f"{name} benchmark failed", "-", limit=results[needed]["error"])
                )
            continue
        try:
            rows.extend(build(ok))
        except (KeyError, TypeError, ZeroDivisionError) as exc:
            rows.append(row(name, f"{name}: results incomplete", "-", limit=repr(exc)))
    return rows


# -- output ---------------------------------------------------------------------------------


def print_table(rows: list[Row]) -> None:
    width = max(len(r["what"]) for r in rows)
    value_w = min(58, max(len(r["value"]) for r in rows))
    group = None
    for r in rows:
        if r["group"] != group:
            group = r["group"]
            print(f"\n{group}")
        target = f"{r['target']} {r['status']}" if r["target"] else ""
        print(f"  {r['what']:<{width}}  {r['value']:<{value_w}}  {target}")


def machine_line(m: dict[str, Any]) -> str:
    return (
        f"{m['cores']} cores ({m['cpu']}), Python {m['python']}, {m['os']}, "
        f"load average {m['load_average']} at the start"
    )


def _cell(r: Row) -> str:
    """A row's target and whether this run met it, in one cell."""
    return f"{r['target']}: {r['status']}" if r["target"] else "-"


def markdown(summary: dict[str, Any]) -> str:
    """The benchmarks page's generated section: the headline figures, then one heading per
    group with its table and its notes, the charts, and how the figures were taken folded."""
    rows: list[Row] = summary["rows"]
    mode = "`python -m bench --quick`" if summary["quick"] else "`python -m bench`"
    groups: dict[str, list[Row]] = {}
    for r in rows:
        groups.setdefault(r["group"], []).append(r)
    missed = [r for r in rows if r["status"] == "not met"]
    targeted = [r for r in rows if r["target"]]
    lines = [
        START,
        f"{len(targeted) - len(missed)} of {len(targeted)} targets met"
        + (f"; not met: {', '.join(r['what'] for r in missed)}." if missed else ".")
        + " Every figure is a ratio or a rate measured side by side in one run; nothing here "
        "is a timed test assertion.",
        "",
        "| group | headline | target |",
        "|---|---|---|",
    ]
    for group, members in groups.items():
        head = next((r for r in members if r["target"]), members[0])
        lines.append(
            f"| [{group}](#{_anchor(group)}) | {head['what']}: {head['value']} | {_cell(head)} |"
        )
    for chart, caption in charts(summary):
        lines += ["", f"![{caption}](assets/pictures/{chart})"]
    for group, members in groups.items():
        lines += ["", f"### {group}", "", "| measured | measure | target |", "|---|---|---|"]
        lines += [f"| {r['value']} | {r['what']} | {_cell(r)} |" for r in members]
        notes = [r for r in members if r["limit"]]
        if notes:
            lines.append("")
            lines += [f"* {r['what']}: {r['limit']}." for r in notes]
    lines += [
        "",
        '??? note "How these figures were taken"',
        "",
        f"    Generated by {mode} from `bench/results/all.json` (the scripts are in `bench/`; "
        "each also runs alone).",
        "",
        f"    Machine: {machine_line(summary['machine'])}. The run took "
        f"{summary['elapsed_s']:.0f} s.",
    ]
    for name, r in summary.get("remeasured", {}).items():
        lines += [
            "",
            f"    Re-measured in a run of its own: {name}, on {machine_line(r['machine'])}.",
        ]
    profile = summary.get("profile")
    if profile:
        lines += ["", f"    {profile}"]
    lines.append(END)
    return "\n".join(lines)


def _anchor(heading: str) -> str:
    """The id MkDocs gives a heading (its toc extension's slug)."""
    slug = re.sub(r"[^\w\s-]", "", heading).strip().lower()
    return re.sub(r"[-\s]+", "-", slug)


PROFILE_NOTE = (
    "The lockstep step loop was profiled (cProfile) and made cheaper without changing "
    "behaviour: deliveries and step results are `msgspec.Struct(gc=False)` instead of "
    "slotted classes (cheaper to build, and invisible to the cyclic collector, "
    "which is what recording every message used to pay for); an in-process firmware finds "
    "the next member once per step; the coordinator, participants and `send` keep one "
    "ZeroMQ poller instead of building one per wait."
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a shorter run (about 1 min)")
    parser.add_argument(
        "--only", help="comma list of benchmarks (default: all); writes no all.json or page"
    )
    parser.add_argument("--no-docs", action="store_true", help="leave docs/benchmarks.md alone")
    parser.add_argument(
        "--smoke",
        action="store_true",
        help="check that every benchmark runs, the falsification one too (quick, one seed); "
        "figures are printed, not judged, and nothing is written",
    )
    parser.add_argument(
        "--merge",
        action="store_true",
        help="with --only: keep all.json's other results (their run's figures stay as they "
        "were) and regenerate the page from them and these",
    )
    args = parser.parse_args(argv)
    if args.merge and not args.only:
        parser.error("--merge re-measures some benchmarks: name them with --only")
    if args.smoke:
        if args.only or args.merge:
            parser.error("--smoke runs every benchmark: leave out --only and --merge")
        return smoke()
    names = args.only.split(",") if args.only else list(BENCHMARKS)
    unknown = sorted(set(names) - set(BENCHMARKS))
    if unknown:
        parser.error(f"unknown benchmark(s) {unknown}; choose from {', '.join(BENCHMARKS)}")

    started = time.perf_counter()
    host = machine()
    print(f"machine: {machine_line(host)}")
    results: dict[str, dict[str, Any]] = {}
    for i, name in enumerate(names, 1):
        print(f"[{i}/{len(names)}] {name} ...", end=" ", flush=True)
        results[name] = run_benchmark(name, args.quick)
        status = "failed: " + results[name]["error"] if "error" in results[name] else "done"
        print(f"{status} ({results[name]['elapsed_s']:.1f} s)")
    elapsed = time.perf_counter() - started

    summary = {
        "quick": args.quick,
        "machine": host,
        "elapsed_s": elapsed,
        "profile": PROFILE_NOTE,
        "results": results,
    }
    if args.merge:
        # The other figures are the earlier run's: its machine line stays, and the
        # re-measured benchmarks say when they were measured.
        previous = json.loads((RESULTS / "all.json").read_text())
        # A benchmark measured alone since (its own results file, not in all.json) joins
        # with its own run's figures and machine line.
        alone = {
            name: json.loads((RESULTS / f"{name}.json").read_text())
            for name in BENCHMARKS
            if name not in previous["results"]
            and name not in results
            and (RESULTS / f"{name}.json").is_file()
        }
        remeasured = {
            **previous.get("remeasured", {}),
            **{name: {"machine": data["machine"]} for name, data in alone.items()},
            **{name: {"machine": host, "elapsed_s": results[name]["elapsed_s"]} for name in names},
        }
        summary = {
            **previous,
            "results": {**previous["results"], **alone, **results},
            "remeasured": remeasured,
        }
    rows = summarize(summary["results"])
    summary["rows"] = rows
    print_table(rows)
    missed = [r for r in rows if r["status"] == "not met"]
    print(f"\n{len(missed)} target(s) not met; took {elapsed:.0f} s")
    if args.only and not args.merge:  # a partial run must not pass for the whole picture
        return 1 if any("error" in r for r in results.values()) else 0
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "all.json").write_text(json.dumps(summary, indent=2) + "\n")
    if not args.no_docs:
        if replace_section(BENCHMARKS_PAGE, START, END, markdown(summary)):
            print(f"updated {BENCHMARKS_PAGE.relative_to(ROOT)}")
        else:
            page = BENCHMARKS_PAGE.name
            print(f"{page} has no {START} ... {END} markers: left alone", file=sys.stderr)
    return 1 if any("error" in r for r in results.values()) else 0


def smoke() -> int:
    """Run every benchmark briefly into a temporary directory; 1 if any of them failed."""
    failed = []
    with tempfile.TemporaryDirectory(prefix="mcs-bench-") as tmp:
        extra = {"search": SEARCH_SMOKE, "f16": F16_SMOKE}
        for i, name in enumerate((*BENCHMARKS, *extra), 1):
            print(f"[{i}/{len(BENCHMARKS) + len(extra)}] {name} ...", end=" ", flush=True)
            if name in extra:
                result = run_benchmark(name, False, Path(tmp), extra[name])
            else:
                result = run_benchmark(name, True, Path(tmp))
            if "error" in result:
                failed.append(name)
                print(f"failed: {result['error']} ({result['elapsed_s']:.1f} s)")
            else:
                print(f"done ({result['elapsed_s']:.1f} s)")
    print(f"{len(failed)} benchmark(s) failed" + (f": {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
