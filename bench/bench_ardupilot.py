"""Real ArduPilot SITL on our worlds: its speed, and the same mission on three autopilots.

1. speed: a copter mission (the PX4 benchmark's: climb to 25 m, two legs, land) flown by
   ArduCopter and a rover mission (three 60 m legs, about a minute of driving) driven by
   ArduRover, at medium fidelity (MuJoCo and the JSON bridge in this process, ArduPilot a
   process, lockstep at 400 Hz). Speed factor = simulated seconds / wall seconds of
   ``firmware.send`` (ArduPilot's start-up, about 40 simulated seconds until its estimator
   lets it arm, included); where the wall time goes: waiting for ArduPilot, stepping the
   world, and the rest (the bridge, the scheduler, the ground station);
2. side by side: that copter mission flown by ArduCopter, real PX4 (with a PX4 SITL binary)
   and the built-in autopilot, all at medium fidelity: the time from takeoff to the end of
   the mission, the horizontal distance between their true paths (mean and max), and each
   one's speed factor in the same run.

Needs ArduPilot's SITL directory: ``--ardupilot-dir DIR`` or ``MCS_ARDUPILOT_DIR``; real PX4
joins with ``--px4-binary`` or ``MCS_PX4_BINARY``. Without ArduPilot the result says so.
``--first-instance N`` (``MCS_FIRST_INSTANCE``) keeps both SITLs' instance numbers at N and
above (beside SITLs already running on the low ones).
Usage: ``python bench/bench_ardupilot.py [--quick]``; prints a table and writes
``bench/results/ardupilot.json``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

import msgspec
from _common import time_steps, write_result
from bench_px4 import PROJ, mission

import multicosim.ardupilot as ardupilot
import multicosim.px4 as px4

TARGET = 10.0  # simulated seconds per wall second, real ArduPilot in lockstep at medium


def copter_mission() -> ardupilot.Configuration:
    """The PX4 benchmark's mission, with time for ArduPilot's start-up as well."""
    return msgspec.structs.replace(mission(), time_limit=300.0)


def rover_mission() -> ardupilot.Configuration:
    """Three 60 m legs at 5 m/s, stopping at the last waypoint."""
    wps = []
    for north, east in ((60.0, 0.0), (60.0, 60.0), (0.0, 60.0)):
        lat, lon = PROJ.reproject(north, east)
        wps.append(ardupilot.Waypoint(lat, lon, 0.0))
    return ardupilot.Configuration(wps, end="land", time_limit=300.0)


def fly_ardupilot(
    cls: type[ardupilot.ArduCopter], sitl: ardupilot.SITL, config: ardupilot.Configuration
) -> tuple[ardupilot.MissionResult, dict[str, Any]]:
    """One mission on ArduPilot (medium); its result and where the wall time went."""
    with cls(fidelity="medium", firmware=sitl, seed=0).start() as simulation:
        spent = time_steps(simulation.world.participant)  # type: ignore[attr-defined]
        bridge = simulation.firmware.firmware_nodes.bridge
        assert bridge is not None
        t0 = time.perf_counter()
        result = simulation.firmware.send(config)
        wall = time.perf_counter() - t0
        frames, waited = bridge.frames, bridge.wait_s
    assert result.completed, result.reason
    simulated = result.end_time - result.start_time
    return result, {
        "sim_s": simulated,
        "send_s": wall,
        "speed_factor": simulated / wall,
        "frames": frames,
        "target": TARGET,
        "share": {
            "ardupilot": waited / wall,
            "world": spent["world_s"] / wall,
            "rest": 1.0 - (waited + spent["world_s"]) / wall,
        },
    }


def fly_px4(sitl: px4.SITL | None) -> tuple[px4.MissionResult, float]:
    """The same copter mission on PX4 (real, or the built-in autopilot), medium; its result
    and speed factor."""
    with px4.PX4(fidelity="medium", firmware=sitl, seed=0).start() as simulation:
        t0 = time.perf_counter()
        result = simulation.firmware.send(mission())
        wall = time.perf_counter() - t0
    assert result.completed, result.reason
    return result, (result.end_time - result.start_time) / wall


def flight_time(result: px4.MissionResult) -> float:
    """Simulated seconds from takeoff (the first armed sample) to the end of the mission."""
    armed = next(s.time for s in result.trajectory if s.armed)
    return result.end_time - armed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ardupilot-dir", default=os.environ.get("MCS_ARDUPILOT_DIR"))
    parser.add_argument("--px4-binary", default=os.environ.get("MCS_PX4_BINARY"))
    parser.add_argument(
        "--first-instance",
        type=int,
        default=int(os.environ.get("MCS_FIRST_INSTANCE", "0")),
        help="the lowest SITL instance number to claim (MCS_FIRST_INSTANCE)",
    )
    parser.add_argument("--quick", action="store_true", help="(the same run: it is short)")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    if not args.ardupilot_dir:
        reason = "no ArduPilot SITL directory (MCS_ARDUPILOT_DIR)"
        write_result("ardupilot", {"skipped": reason}, args.output)
        print(f"skipped: {reason}")
        return 0

    sitl = ardupilot.SITL(directory=args.ardupilot_dir, first_instance=args.first_instance)

    # 1. speed
    copter, copter_speed = fly_ardupilot(ardupilot.ArduCopter, sitl, copter_mission())
    _, rover_speed = fly_ardupilot(ardupilot.ArduRover, sitl, rover_mission())
    speed = {"copter": copter_speed, "rover": rover_speed}

    # 2. side by side
    flights: dict[str, px4.MissionResult] = {"ArduCopter": copter}
    speeds = {"ArduCopter": copter_speed["speed_factor"]}
    flights["built-in"], speeds["built-in"] = fly_px4(None)
    if args.px4_binary:
        px4_sitl = px4.SITL(binary=args.px4_binary, first_instance=args.first_instance)
        flights["real PX4"], speeds["real PX4"] = fly_px4(px4_sitl)
    compared: dict[str, Any] = {
        name: {
            "flight_s": flight_time(r),
            "reached": [w.index for w in r.reached],
            "speed_factor": speeds[name],
        }
        for name, r in flights.items()
    }
    names = list(flights)
    pairs: dict[str, Any] = {}
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            mean, worst = flights[a].path_gap(flights[b])
            pairs[f"{a} vs {b}"] = {"mean_distance_m": mean, "max_distance_m": worst}

    out = {"speed": speed, "side_by_side": {"autopilots": compared, "paths": pairs}}
    print(f"{'run':<10} {'sim s':>6} {'wall s':>7} {'x real':>7}  ArduPilot / world / rest")
    for name, r in speed.items():
        sh = r["share"]
        print(
            f"{name:<10} {r['sim_s']:6.1f} {r['send_s']:7.2f} {r['speed_factor']:7.1f}  "
            f"{sh['ardupilot']:.0%} / {sh['world']:.0%} / {sh['rest']:.0%}"
        )
    for name, c in compared.items():
        print(
            f"{name:<12} takeoff to landed {c['flight_s']:.1f} s, waypoints {c['reached']}, "
            f"{c['speed_factor']:.1f}x real time"
        )
    for pair, d in pairs.items():
        mean, worst = d["mean_distance_m"], d["max_distance_m"]
        print(f"{pair}: path distance mean {mean:.2f} m, max {worst:.2f} m")
    path = write_result("ardupilot", out, args.output)
    print(f"wrote {path.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
