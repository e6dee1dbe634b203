"""The sweep: what a killed run leaves behind is removed; live runs are left alone."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from typing import Any

import pytest

from multicosim.docker import ContainerComponent, ContainerSimulator, sweep

# Each test here sweeps the whole engine, which would remove what a killed host of another
# test left before that test looks at it: under xdist they all run on one worker.
pytestmark = pytest.mark.xdist_group("docker-sweep")

WORLD = "multicosim participant multicosim.docker._selftest:World"

HOST_PROGRAM = textwrap.dedent(
    """
    import sys, time
    from multicosim.docker import ContainerComponent, ContainerSimulator
    sim = ContainerSimulator()
    sim.add(ContainerComponent(sys.argv[1], {world!r}, name="world"))
    simulation = sim.start()
    print(simulation.run_id, flush=True)
    time.sleep(600)
    """
).format(world=WORLD)


def test_sweep_removes_what_a_killed_run_left(engine: Any, image: str, ours: Any) -> None:
    with subprocess.Popen(
        [sys.executable, "-c", HOST_PROGRAM, image], stdout=subprocess.PIPE, text=True
    ) as host:
        try:
            assert host.stdout is not None
            run_id = host.stdout.readline().strip()
            assert run_id.startswith("mcs-"), f"the host program failed (exit {host.poll()})"
        finally:
            host.send_signal(signal.SIGKILL)
    assert ours(run=run_id) == ([f"/{run_id}-world"], [run_id])
    # The end-of-session sweep removes only its own session's leftovers.
    assert sweep(only_current_process=True).containers == ()
    assert ours(run=run_id) == ([f"/{run_id}-world"], [run_id])

    # A live simulation of this process must survive the same sweep.
    sim = ContainerSimulator()
    sim.add(ContainerComponent(image, WORLD, name="world"))
    with sim.start() as alive:
        report = sweep()
        assert f"{run_id}-world" in report.containers
        assert run_id in report.networks
        assert ours(run=run_id) == ([], [])
        assert ours(run=alive.run_id) == ([f"/{alive.run_id}-world"], [alive.network])
        alive.advance(0.02)  # and it still runs


def test_sweep_at_session_end_removes_this_process_leftovers(
    engine: Any, image: str, ours: Any
) -> None:
    sim = ContainerSimulator()
    sim.add(ContainerComponent(image, WORLD, name="world"))
    simulation = sim.start()
    # Still ours and alive: left alone (a dead run's leftovers on the engine may go).
    assert f"{simulation.run_id}-world" not in sweep().containers
    report = sweep(include_current_process=True)
    assert report.containers == (f"{simulation.run_id}-world",)
    assert report.networks == (simulation.run_id,)
    assert ours(run=simulation.run_id) == ([], [])
    # The simulation notices its container was removed behind its back.
    with pytest.raises(ExceptionGroup):
        simulation.stop()


def test_sweep_command(engine: Any) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "multicosim", "sweep"],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ},
    )
    assert result.stdout.startswith("removed ")


def test_components_of_a_killed_host_exit_by_themselves(engine: Any, image: str, ours: Any) -> None:
    # In a container the parent never changes, so the component relies on noticing that the
    # coordinator's connection dropped. Another test's sweep may remove the container at any
    # moment (its host is dead), so the proof is the engine's event history: the container
    # died without anyone killing it.
    import time

    since = int(time.time()) - 1
    with subprocess.Popen(
        [sys.executable, "-c", HOST_PROGRAM, image], stdout=subprocess.PIPE, text=True
    ) as host:
        try:
            assert host.stdout is not None
            run_id = host.stdout.readline().strip()
            assert run_id.startswith("mcs-"), f"the host program failed (exit {host.poll()})"
        finally:
            host.send_signal(signal.SIGKILL)
    name = f"{run_id}-world"

    def history() -> list[dict[str, Any]]:
        events = engine.events(
            since=since, until=int(time.time()) + 1, filters={"container": name}, decode=True
        )
        return [e for e in events if e.get("Type") == "container"]

    deadline = time.monotonic() + 20
    while not any(e["Action"] == "die" for e in history()) and time.monotonic() < deadline:
        time.sleep(0.5)
    actions = [e["Action"] for e in history()]
    assert "die" in actions, actions
    assert "kill" not in actions[: actions.index("die")], actions
    die = next(e for e in history() if e["Action"] == "die")
    assert die["Actor"]["Attributes"]["exitCode"] == "0"
    sweep()
    assert ours(run=run_id) == ([], [])
