"""PX4 scenario speed: a 60 s mission at low and medium fidelity, and raw MuJoCo, in one run.

1. low: point-mass world, autopilot and ground station in one process (target >= 1000x);
2. medium: MuJoCo quadrotor world and autopilot as two processes in lockstep exchanging
   MAVLink HIL frames, ground station in this process (target >= 10x);
3. medium in-process: the same models without process boundaries (what IPC costs);
4. raw MuJoCo: ``mj_step`` of the same MJCF quadrotor for the same simulated time, in batches
   of one lockstep period (what the world does between two exchanges), hovering.

Speed factor = simulated seconds / wall seconds of ``firmware.send(mission)`` (start and stop
timed separately). Usage: ``python bench/bench_px4.py [--repeat N]``; prints a table and
writes ``bench/results/px4.json``. pymavlink uses ``fastcrc`` for its checksums when it is
installed; the table records whether it was.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.px4._geo import LocalProjection
from multicosim.px4._simulator import PX4Component, WorldComponent

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)


def mission() -> px4.Configuration:
    """About 60 s of flight: climb, two legs, land."""
    wps = []
    for north, east, alt in ((30.0, 30.0, 25.0), (85.0, -7.0, 30.0)):
        lat, lon = PROJ.reproject(north, east)
        wps.append(px4.Waypoint(lat, lon, alt))
    return px4.Configuration(wps, end="land", time_limit=120.0)


def fly(fidelity: str, process: bool | None) -> dict[str, float]:
    world = px4.MuJoCo()
    sim = mcs.ProcessSimulator(seed=0)
    sim.add(WorldComponent(world, fidelity, process=process))  # type: ignore[arg-type]
    fw = sim.add(PX4Component(world, fidelity, process=process))  # type: ignore[arg-type]
    t0 = time.perf_counter()
    simulation = sim.start()
    t1 = time.perf_counter()
    try:
        result = simulation.get(fw).send(mission())
        t2 = time.perf_counter()
    finally:
        simulation.stop()
    t3 = time.perf_counter()
    assert result.completed, result.reason
    simulated = result.end_time - result.start_time
    return {
        "simulated_s": simulated,
        "wall_s": t2 - t1,
        "speed": simulated / (t2 - t1),
        "start_s": t1 - t0,
        "stop_s": t3 - t2,
        "samples": len(result.trajectory),
    }


def raw_mujoco(simulated: float) -> dict[str, float]:
    import mujoco

    from multicosim.px4._world import model_path

    world = px4.MuJoCo()
    model = mujoco.MjModel.from_xml_path(model_path())
    model.opt.timestep = world.timestep
    data = mujoco.MjData(model)
    data.ctrl[:] = 0.47  # about hover
    periods = round(simulated / world.period)
    t0 = time.perf_counter()
    for _ in range(periods):
        mujoco.mj_step(model, data, nstep=world.substeps)
    wall = time.perf_counter() - t0
    return {
        "simulated_s": periods * world.period,
        "wall_s": wall,
        "speed": periods * world.period / wall,
    }


def best(runs: list[dict[str, float]]) -> dict[str, float]:
    return max(runs, key=lambda r: r["speed"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per row (best is kept)")
    args = parser.parse_args(argv)
    rows: dict[str, Any] = {}
    rows["low"] = best([fly("low", None) for _ in range(max(5, args.repeat))])  # cheap: more tries
    rows["medium"] = best([fly("medium", None) for _ in range(max(1, args.repeat - 1))])
    rows["medium_in_process"] = best([fly("medium", False) for _ in range(args.repeat)])
    rows["raw_mujoco"] = best(
        [raw_mujoco(rows["medium"]["simulated_s"]) for _ in range(args.repeat)]
    )
    rows["medium_vs_raw_mujoco"] = rows["raw_mujoco"]["speed"] / rows["medium"]["speed"]
    meta = {
        "python": sys.version.split()[0],
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg()[0],
        "fastcrc": importlib.util.find_spec("fastcrc") is not None,
        "world": {"timestep": px4.MuJoCo().timestep, "period": px4.MuJoCo().period},
        "targets": {"low": 1000.0, "medium": 10.0},
    }
    out = {"meta": meta, "results": rows}
    print(f"{'run':20s} {'sim s':>7s} {'wall s':>8s} {'speed':>9s}")
    for name, r in rows.items():
        if isinstance(r, dict):
            print(f"{name:20s} {r['simulated_s']:7.1f} {r['wall_s']:8.3f} {r['speed']:8.0f}x")
    print(f"raw MuJoCo is {rows['medium_vs_raw_mujoco']:.0f}x faster than the medium run")
    dest = Path(__file__).parent / "results" / "px4.json"
    dest.parent.mkdir(exist_ok=True)
    dest.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
