"""A component container ends with its host, even in the middle of a step."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from docker_helpers import wait_for

# The host: a container participant that gets stuck in its step, then a step that never ends.
HOST = """
import sys
import multicosim as mcs
from multicosim.docker import ContainerComponent, ContainerSimulator

simulator = ContainerSimulator()
simulator.add(
    ContainerComponent(sys.argv[1], "multicosim participant multicosim.testing:Stuck")
)
simulation = simulator.start()
print(simulation.run_id, flush=True)
simulation.advance(3600.0)
"""


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_container_component_exits_when_its_host_dies_mid_step(
    engine: Any, image: str, tmp_path: Path, sig: signal.Signals
) -> None:
    from multicosim.docker import sweep

    script = tmp_path / "host.py"
    script.write_text(HOST)
    host = subprocess.Popen([sys.executable, str(script), image], stdout=subprocess.PIPE, text=True)
    try:
        assert host.stdout is not None
        run_id = host.stdout.readline().strip()
        assert run_id, "the host did not start its simulation"
        (container,) = engine.api.containers(filters={"label": f"multicosim.run={run_id}"})
        assert wait_for(lambda: "stuck at t=" in _logs(engine, container["Id"]))
        host.send_signal(sig)
        host.wait(30)
        # Its watch notices the lost connection and ends the busy process; init follows.
        seen: list[str] = []

        def ended() -> bool:
            seen.append(_logs(engine, container["Id"]))
            return _state(engine, container["Id"]) != "running"

        assert wait_for(ended), seen[-1]
        # Another session on the engine may sweep the dead host's container at any time;
        # what it printed before was seen.
        assert any("the simulation host has gone" in text for text in seen) or (
            _state(engine, container["Id"]) == "removed"
        ), seen[-1]
    finally:
        if host.poll() is None:
            host.kill()
            host.wait()
        if host.stdout is not None:
            host.stdout.close()
        sweep()  # the dead host's container and network (its own session's, not ours)


def _logs(engine: Any, container_id: str) -> str:
    from multicosim.docker.engine import APIError

    try:
        raw: bytes = engine.api.logs(container_id)
    except APIError:  # removed (or being removed) by a sweep
        return ""
    return raw.decode(errors="replace")


def _state(engine: Any, container_id: str) -> str:
    from multicosim.docker.engine import APIError

    try:
        state: str = engine.api.inspect_container(container_id)["State"]["Status"]
    except APIError:
        return "removed"
    return state
