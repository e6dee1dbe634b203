"""Participants and a driver for the Ray placement's tests: importable by programs on nodes.

Run as a script, it is a driver of its own: it joins the cluster of ``MCS_RAY_ADDRESS``,
starts a rover simulation on the ``ray`` placement, prints (one JSON line) the process ids
of its components' programs and actors, and flies a mission long enough to be interrupted.
"""

from __future__ import annotations

import json

import multicosim as mcs


class Crasher:
    """A participant that raises in its step once ``after`` simulated seconds have passed."""

    period = 0.01

    def __init__(self, after: float = 0.05) -> None:
        self.after = after

    def setup(self, ctx: mcs.StepContext) -> None:
        """Say it is up (the log tail shows it)."""
        print("the crasher is up", flush=True)

    def step(self, ctx: mcs.StepContext) -> None:
        """Raise once it is time."""
        if ctx.time >= self.after:
            raise RuntimeError(f"the crasher gave up at t={ctx.time:g} s")


def crasher() -> Crasher:
    """The Crasher, as a participant factory."""
    return Crasher()


def broken() -> Crasher:
    """A factory that fails before its participant can join."""
    print("about to fail", flush=True)
    raise ValueError("this participant cannot be built")


class Idle:
    """A participant that does nothing, every 10 ms of simulated time."""

    period = 0.01

    def setup(self, ctx: mcs.StepContext) -> None:
        """Nothing to subscribe to."""

    def step(self, ctx: mcs.StepContext) -> None:
        """Nothing to compute."""


def idle() -> Idle:
    """The Idle participant, as a factory."""
    return Idle()


def _drive() -> None:
    import multicosim.rover as rover
    from multicosim.ray import RaySimulation

    with rover.Rover(fidelity="medium", placement="ray", seed=1).start() as simulation:
        assert isinstance(simulation.simulation, RaySimulation)
        nodes = simulation.simulation.ray_nodes()
        pids = {
            "programs": [n.pid for n in nodes],
            "actors": [n.handle.worker_pid for n in nodes],
            "run_dir": str(simulation.run_dir),
        }
        print(json.dumps(pids), flush=True)
        # Far longer than any test waits: it ends by a signal.
        simulation.controller.send(rover.Mission(speed=1.0, wait=0.5, distance=10_000.0))


if __name__ == "__main__":
    _drive()
