"""PX4 scenario speed: a 60 s mission at each fidelity, and raw MuJoCo, in one run.

1. low: point-mass world, autopilot and ground station in one process (target >= 1000x);
2. medium: MuJoCo quadrotor world and autopilot as two processes in lockstep exchanging
   MAVLink HIL frames, ground station in this process (target >= 10x);
3. medium in-process: the same models without process boundaries (what IPC costs);
4. high: MuJoCo at a four times finer step, world and autopilot as Docker containers
   (target >= 5x); with no Docker engine, as local processes (the reason is recorded);
5. raw MuJoCo: ``mj_step`` of the same MJCF quadrotor and world configuration for the same
   simulated time, in batches of one lockstep period, hovering.

Speed factor = simulated seconds / wall seconds of ``firmware.send(mission)`` (start and stop
timed separately). Usage: ``python bench/bench_px4.py [--repeat N] [--quick]``; prints a
table and writes ``bench/results/px4.json``. pymavlink uses ``fastcrc`` for its checksums when
it is installed; the results record whether it was.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path
from typing import Any

from _common import docker_reason, write_result

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.px4.scenario import PX4Component, WorldComponent, default_world

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
TARGETS = {"low": 1000.0, "medium": 10.0, "high": 5.0}


def mission() -> px4.Configuration:
    """About 60 s of flight: climb, two legs, land."""
    wps = []
    for north, east, alt in ((30.0, 30.0, 25.0), (85.0, -7.0, 30.0)):
        lat, lon = PROJ.reproject(north, east)
        wps.append(px4.Waypoint(lat, lon, alt))
    return px4.Configuration(wps, end="land", time_limit=120.0)


def _timed(start: Any) -> dict[str, Any]:
    t0 = time.perf_counter()
    simulation = start()
    t1 = time.perf_counter()
    try:
        result = simulation.firmware.send(mission())
        t2 = time.perf_counter()
    finally:
        simulation.stop()
    t3 = time.perf_counter()
    assert result.completed, result.reason
    simulated = result.end_time
    return {
        "sim_s": simulated,
        "mission_s": result.end_time - result.start_time,
        "send_s": t2 - t1,
        "speed_factor": simulated / (t2 - t1),
        "start_s": t1 - t0,
        "stop_s": t3 - t2,
    }


def fly(fidelity: str, placement: str | None = None) -> dict[str, Any]:
    """One mission through the public simulator, ``px4.PX4`` (None: the fidelity's default
    placement)."""
    simulator = px4.PX4(fidelity=fidelity, placement=placement, seed=0)  # type: ignore[arg-type]
    return {"placement": simulator.placement.name, **_timed(simulator.start)}


def fly_in_process(fidelity: str) -> dict[str, Any]:
    """The medium models with world and autopilot in this process (no IPC)."""
    world = default_world(fidelity)  # type: ignore[arg-type]

    def start() -> Any:
        sim = mcs.ProcessSimulator(seed=0)
        sim.add(WorldComponent(world, fidelity, placement="in-process"))  # type: ignore[arg-type]
        fw = sim.add(PX4Component(world, fidelity, placement="in-process"))  # type: ignore[arg-type]
        return _Adapter(sim.start(), fw)

    return {"placement": "in-process", **_timed(start)}


class _Adapter:
    def __init__(self, simulation: Any, fw: Any) -> None:
        self.simulation = simulation
        self.firmware = simulation.get(fw)

    def stop(self) -> None:
        self.simulation.stop()


def raw_mujoco(fidelity: str, simulated: float, repeat: int) -> dict[str, float]:
    """Raw ``mj_step`` of the quadrotor, one lockstep period per call, hovering."""
    import mujoco

    from multicosim.quadrotor.airframe import NONE_IRIS

    world = default_world(fidelity)  # type: ignore[arg-type]
    best = float("inf")
    periods = round(simulated / world.period)
    for _ in range(repeat):
        model = mujoco.MjModel.from_xml_string(NONE_IRIS.mjcf())
        model.opt.timestep = world.timestep
        model.opt.iterations = world.iterations
        data = mujoco.MjData(model)
        data.ctrl[:] = 0.525  # about hover
        t0 = time.perf_counter()
        for _ in range(periods):
            mujoco.mj_step(model, data, nstep=world.steps_per_period)
        best = min(best, time.perf_counter() - t0)
    sim = periods * world.period
    return {"sim_s": sim, "wall_s": best, "speed_factor": sim / best, "timestep": world.timestep}


def high_placement() -> tuple[str, str | None]:
    """Docker where an engine runs and PX4 takes it, else local processes and why."""
    reason = docker_reason()
    if reason is not None:
        return "process", reason
    try:
        px4.PX4(fidelity="high", placement="docker")
    except Exception as exc:
        return "process", f"PX4's docker placement is not available: {exc}"
    return "docker", None


def best(runs: list[dict[str, Any]]) -> dict[str, Any]:
    return max(runs, key=lambda r: r["speed_factor"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="runs per row (best is kept)")
    parser.add_argument("--quick", action="store_true", help="one run per row")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    placement, fallback = high_placement()

    runs: dict[str, list[dict[str, Any]]] = {
        "low": [],
        "medium": [],
        "medium_in_process": [],
        "high": [],
    }
    for i in range(repeat):
        runs["low"] += [fly("low") for _ in range(3)]  # cheap: more tries
        runs["medium"].append(fly("medium"))
        runs["medium_in_process"].append(fly_in_process("medium"))
        if i == 0:
            runs["high"].append(fly("high", placement))
    rows = {name: best(r) for name, r in runs.items()}
    raw = {
        level: raw_mujoco(level, rows[level]["sim_s"], max(2, repeat))
        for level in ("medium", "high")
    }
    for name, row in rows.items():
        level = name.split("_")[0]
        ref = raw.get(level, raw["medium"])
        row["over_raw"] = ref["speed_factor"] / row["speed_factor"]
        row["raw_mujoco_model"] = level if level in raw else "medium"
        if name in TARGETS:
            row["target"] = TARGETS[name]
    rows["high"]["fallback_reason"] = fallback
    out = {
        "fastcrc": importlib.util.find_spec("fastcrc") is not None,
        "worlds": {
            level: {
                "timestep": default_world(level).timestep,
                "period": default_world(level).period,
            }  # type: ignore[arg-type]
            for level in ("medium", "high")
        },
        "levels": rows,
        "raw_mujoco": raw,
    }
    print(f"{'run':<28} {'sim s':>6} {'wall s':>8} {'x real':>8} {'/ raw':>7}")
    for name, r in rows.items():
        label = f"{name} ({r['placement']})"
        print(
            f"{label:<28} {r['sim_s']:6.1f} {r['send_s']:8.3f} {r['speed_factor']:8.0f}"
            f" {r['over_raw']:7.1f}"
        )
    for level, r in raw.items():
        print(f"{'raw mj_step (' + level + ')':<28} {r['sim_s']:6.1f} {r['wall_s']:8.3f}")
    if fallback:
        print(f"high ran as local processes: {fallback}")
    path = write_result("px4", out, args.output)
    print(f"wrote {path.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
