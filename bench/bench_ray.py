"""The ``ray`` placement's cost per lockstep step against the ``process`` placement, in one run.

On a Ray cluster of two nodes on this machine (started here; ``--address`` joins another),
measures, side by side:

* ``step``: one lockstep exchange (Step/Yield) of a participant that does nothing, driven by
  ``simulation.advance(period)``: its program a local process (``process``) or a Ray actor's
  program on a node of the cluster (``ray``). Timed call by call in alternating rounds; the
  ratio of medians (and of the 10th percentiles) is ray over process.
* ``rover``: the rover at medium fidelity flying a 60 s mission (MuJoCo world and FSA
  controller; on ``ray`` one on each node): wall time of ``controller.send`` per world
  period (one lockstep step of the world, 25 ms simulated), in interleaved runs (best and
  median), and the wall time to start and to stop the simulation.

Both runs of a seed fly the same trajectory (checked). Prints a table and writes
``bench/results/ray.json``.

    python bench/bench_ray.py [--iterations N] [--rounds R] [--repeat N] [--quick]
                              [--address HOST:PORT]
"""

from __future__ import annotations

import argparse
import contextlib
import math
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from _common import write_result

import multicosim as mcs
import multicosim.rover as rover
from multicosim.placement import ParticipantProgram, Placement, get_placement
from multicosim.ray import LocalCluster, Ray, RaySimulation, RaySimulator

STEP_PERIOD = 0.001
# About 60 s of simulated time: wait, 50 m, a right-angle turn, 55 m and stop, at 2 m/s (as
# bench_rover.py flies it).
MISSION = rover.Mission(
    speed=2.0, wait=5.0, distance=50.0, turn_angle=math.radians(90.0), final_distance=55.0
)


class Idle:
    """A participant whose step does nothing: what is left is the exchange itself."""

    period = STEP_PERIOD

    def setup(self, ctx: mcs.StepContext) -> None:
        """Nothing to subscribe to."""

    def step(self, ctx: mcs.StepContext) -> None:
        """Nothing to compute."""


@contextlib.contextmanager
def cluster(address: str | None) -> Iterator[Ray]:
    """The placement on the cluster at ``address``, or on two local nodes started here."""
    import ray

    with contextlib.ExitStack() as stack:
        if address is None:
            address = stack.enter_context(LocalCluster(nodes=2, num_cpus=1)).address
        placement = Ray(address)
        placement.prepare()
        stack.callback(ray.shutdown)
        yield placement


def time_calls(call: Callable[[], object], n: int) -> list[int]:
    """Wall time of ``n`` calls, one by one, in nanoseconds."""
    clock = time.perf_counter_ns
    out = [0] * n
    for i in range(n):
        t0 = clock()
        call()
        out[i] = clock() - t0
    return out


def summary(samples: list[int]) -> dict[str, float]:
    """Median and spread in microseconds."""
    q = statistics.quantiles(samples, n=10)
    return {
        "median_us": round(statistics.median(samples) / 1e3, 2),
        "p10_us": round(q[0] / 1e3, 2),
        "p90_us": round(q[-1] / 1e3, 2),
        "n": len(samples),
    }


def bench_step(placement: Ray, iterations: int, rounds: int) -> dict[str, Any]:
    """One lockstep exchange of an idle participant: a local process against a Ray actor's."""
    program = ParticipantProgram("bench_ray:Idle", None, "idle")
    local = mcs.ProcessSimulator()
    local.add(get_placement("process").participant(program))
    remote = RaySimulator(placement.address)
    remote.add(placement.participant(program))
    with local.start() as on_process, remote.start() as on_ray:
        calls = {
            "process": lambda: on_process.advance(STEP_PERIOD),
            "ray": lambda: on_ray.advance(STEP_PERIOD),
        }
        for call in calls.values():
            time_calls(call, max(20, iterations // 10))  # warm-up (and the t=0 step)
        samples: dict[str, list[int]] = {name: [] for name in calls}
        per_round = max(1, iterations // rounds)
        for r in range(rounds):
            order = list(calls.items())
            if r % 2:
                order.reverse()
            for name, call in order:
                samples[name].extend(time_calls(call, per_round))
    stats = {name: summary(s) for name, s in samples.items()}
    return {
        "stats": stats,
        "ratio": round(stats["ray"]["median_us"] / stats["process"]["median_us"], 3),
        "ratio_p10": round(stats["ray"]["p10_us"] / stats["process"]["p10_us"], 3),
    }


def run_mission(placement: Placement, seed: int) -> dict[str, Any]:
    """One medium-fidelity rover mission: start, send and stop wall times, cost per step."""
    t0 = time.perf_counter()
    simulator = rover.Rover(fidelity="medium", placement=placement, seed=seed)
    simulation = simulator.start()
    t1 = time.perf_counter()
    try:
        nodes = 0
        if isinstance(simulation.simulation, RaySimulation):
            nodes = len({n.node_id for n in simulation.simulation.ray_nodes()})
        trajectory = simulation.controller.send(MISSION)
        t2 = time.perf_counter()
    finally:
        simulation.stop()
    t3 = time.perf_counter()
    if not trajectory.completed:
        raise SystemExit(f"{placement.name}: the mission did not complete: {trajectory.reason}")
    steps = round(trajectory.final.time / simulator.config.world.period)
    return {
        "start_s": t1 - t0,
        "send_s": t2 - t1,
        "stop_s": t3 - t2,
        "sim_s": trajectory.final.time,
        "steps": steps,
        "us_per_step": (t2 - t1) / steps * 1e6,
        "ray_nodes": nodes,
        "final": [trajectory.final.x, trajectory.final.y],
    }


def bench_rover(placement: Ray, repeat: int) -> dict[str, Any]:
    """The rover's mission on both placements, interleaved; best and median per step."""
    runs: dict[str, list[dict[str, Any]]] = {"process": [], "ray": []}
    places: dict[str, Placement] = {"process": get_placement("process"), "ray": placement}
    for i in range(repeat):
        order = list(places.items()) if i % 2 == 0 else list(reversed(places.items()))
        for name, where in order:
            runs[name].append(run_mission(where, seed=i))
        if runs["process"][-1]["final"] != runs["ray"][-1]["final"]:
            raise SystemExit(f"seed {i}: the placements flew different trajectories")
    out: dict[str, Any] = {}
    for name, r in runs.items():
        best = min(r, key=lambda x: x["us_per_step"])
        out[name] = {
            **best,
            "median_us_per_step": statistics.median(x["us_per_step"] for x in r),
            "median_start_s": statistics.median(x["start_s"] for x in r),
            "median_stop_s": statistics.median(x["stop_s"] for x in r),
            "runs": len(r),
        }
    out["ratio"] = round(out["ray"]["us_per_step"] / out["process"]["us_per_step"], 3)
    out["ratio_median"] = round(
        out["ray"]["median_us_per_step"] / out["process"]["median_us_per_step"], 3
    )
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the table, write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=2000, help="exchanges per case")
    parser.add_argument("--rounds", type=int, default=10, help="alternating rounds")
    parser.add_argument("--repeat", type=int, default=3, help="rover missions per placement")
    parser.add_argument("--quick", action="store_true", help="fewer exchanges, one mission")
    parser.add_argument("--address", default=None, help="a Ray cluster's HOST:PORT to join")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    iterations, repeat = (300, 1) if args.quick else (args.iterations, args.repeat)

    with cluster(args.address) as placement:
        import ray

        nodes = len([n for n in ray.nodes() if n["Alive"]])
        step = bench_step(placement, iterations, args.rounds)
        mission = bench_rover(placement, repeat)

    report = {
        "cluster": {"nodes": nodes, "address": "local" if args.address is None else "given"},
        "step": step,
        "rover_medium": mission,
    }
    s, m = step["stats"], mission
    print(f"ray placement against process, {nodes} Ray nodes on this machine")
    print(f"{'case':<40} {'process':>10} {'ray':>10} {'ratio':>7}")
    print(
        f"{'idle step, median us':<40} {s['process']['median_us']:>10.1f}"
        f" {s['ray']['median_us']:>10.1f} {step['ratio']:>7.2f}"
    )
    print(
        f"{'idle step, p10 us':<40} {s['process']['p10_us']:>10.1f}"
        f" {s['ray']['p10_us']:>10.1f} {step['ratio_p10']:>7.2f}"
    )
    print(
        f"{'rover medium, us per step (best)':<40} {m['process']['us_per_step']:>10.1f}"
        f" {m['ray']['us_per_step']:>10.1f} {m['ratio']:>7.2f}"
    )
    print(
        f"{'rover medium, us per step (median)':<40} {m['process']['median_us_per_step']:>10.1f}"
        f" {m['ray']['median_us_per_step']:>10.1f} {m['ratio_median']:>7.2f}"
    )
    for what in ("start", "stop"):
        key = f"median_{what}_s"
        print(
            f"{'rover medium, ' + what + ' s (median)':<40} {m['process'][key]:>10.2f}"
            f" {m['ray'][key]:>10.2f} {m['ray'][key] / m['process'][key]:>7.2f}"
        )
    print(f"rover components on {m['ray']['ray_nodes']} Ray nodes; same trajectories: yes")
    out = write_result("ray", report, args.output)
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
