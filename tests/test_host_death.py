"""Components die with their host, even in the middle of a step; runaway handlers time out."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
from multicosim import testing

pytestmark = pytest.mark.usefixtures("no_leaks")

# The host: a stuck participant (directly its child, or under a shell so that only the
# component's own watch can notice the host's death), a firmware process, then a step that
# never ends. It prints the pids once the participant is stuck.
HOST = """
import sys
import time
import multicosim as mcs

via_shell = sys.argv[1] == "shell"
command = "python -m multicosim participant multicosim.testing:Stuck"
if via_shell:  # "; true": the shell must not exec the program, it stays its parent
    command = ["sh", "-c", sys.executable + command.removeprefix("python") + "; true"]
simulator = mcs.ProcessSimulator(run_dir=sys.argv[2])
simulator.add(mcs.ProcessComponent(command, name="stuck"))
simulator.add(
    mcs.ProcessFirmwareComponent("python -m multicosim serve multicosim.testing:echo")
)
simulation = simulator.start()
print("started", flush=True)
simulation.advance(3600.0)
"""


def _pids(runs: Path) -> tuple[int, int] | None:
    """(stuck participant, echo firmware) once the participant says it is stuck."""
    run_dir = next(runs.glob("mcs-*"), None)
    if run_dir is None:
        return None
    try:
        stuck = re.search(r"\(pid (\d+)\)", (run_dir / "stuck.log").read_text())
        # The run's record of the process groups it started, in start order.
        records = (run_dir / "pids").read_text().splitlines()
    except OSError:
        return None
    if stuck is None or len(records) < 2:
        return None
    return int(stuck.group(1)), int(records[1].split()[0])


def _gone(pid: int, timeout: float = 30.0) -> bool:
    """Wait until ``pid`` has exited (a zombie counts); False if it still runs at the end."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] in ("Z", "X"):
                    return True
        except OSError:
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)


@pytest.mark.parametrize("via", ["direct", "shell"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_components_die_with_their_host_mid_step(
    tmp_path: Path, sig: signal.Signals, via: str
) -> None:
    script = tmp_path / "host.py"
    script.write_text(HOST)
    run_dir = tmp_path / "run"
    host = subprocess.Popen([sys.executable, str(script), via, str(run_dir)])
    pids: tuple[int, int] | None = None
    try:
        deadline = time.monotonic() + 60
        while (pids := _pids(run_dir)) is None and time.monotonic() < deadline:
            assert host.poll() is None, "the host failed before its participant got stuck"
            time.sleep(0.05)
        assert pids is not None, "the participant never got stuck in its step"
        host.send_signal(sig)
        host.wait(30)
        stuck, echo = pids
        assert _gone(stuck), f"the participant stuck in its step outlived its host ({via})"
        assert _gone(echo), "the firmware outlived its host"
        if via == "shell":  # not the host's child: its own watch ended it
            (log,) = run_dir.glob("*/stuck.log")
            assert "the simulation host has gone" in log.read_text()
    finally:
        if host.poll() is None:
            host.kill()
            host.wait()
        for pid in pids or ():
            if not _gone(pid, timeout=0):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)


def test_looping_in_process_firmware_times_out() -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    node_id = simulator.add(mcs.InProcessFirmwareComponent(testing.misbehave, timeout=0.3))
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        with pytest.raises(
            mcs.NodeTimeoutError, match=r"'misbehave' did not answer within 0\.3 s"
        ) as info:
            node.send(testing.Misbehave(how="spin", seconds=3600.0))
        assert info.value.name == "misbehave"
        # The node still works, and no interruption is left pending for later calls.
        assert node.send(testing.Misbehave(how="fine")) == "fine"
        assert node.send(testing.Misbehave(how="spin", seconds=0.01), timeout=30.0) == "spin"


def test_handler_that_swallows_the_timeout_is_still_stopped() -> None:
    @mcs.firmware(msgtype=testing.Echo, period=0.01)
    def stubborn(msg: testing.Echo, ctx: mcs.FirmwareContext) -> testing.Echo:
        while True:
            with contextlib.suppress(Exception):  # a handler that swallows every error
                ctx.step()
                time.sleep(0.3)  # longer between two steps than its timeout allows

    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.InProcessFirmwareComponent(stubborn, timeout=0.2))
    with simulator.start() as simulation, pytest.raises(mcs.NodeTimeoutError, match="stubborn"):
        simulation.get(node_id).send(testing.Echo(text="x"))


def test_per_call_timeout_and_its_validation() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.InProcessFirmwareComponent(testing.misbehave))
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        with pytest.raises(mcs.NodeTimeoutError, match=r"within 0\.2 s"):
            node.send(testing.Misbehave(how="spin", seconds=3600.0), timeout=0.2)
        with pytest.raises(mcs.ConfigurationError, match="timeout"):
            node.send(testing.Misbehave(how="fine"), timeout=float("inf"))
    with pytest.raises(mcs.ConfigurationError, match="timeout=0"):
        mcs.InProcessFirmwareComponent(testing.misbehave, timeout=0)


# -- in-process participants: every step bounded by the step timeout ----------------------


class Spin:
    """A participant whose step never returns from t=0.5 s on (a busy loop, no clock)."""

    period = 0.01

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        while ctx.time >= 0.5:
            pass


DRIVE = "python -m multicosim serve multicosim.testing:drive --port {port}"


@pytest.mark.parametrize("driver", ["process", "in-process"])
def test_spinning_in_process_participant_times_out_like_a_process(driver: str) -> None:
    simulator = mcs.ProcessSimulator(step_timeout=1.0)
    simulator.add(mcs.InProcessComponent(Spin, name="cart"))
    node_id: mcs.NodeId[Any]
    if driver == "process":
        node_id = simulator.add(
            mcs.ProcessFirmwareComponent(
                DRIVE, msgtype=testing.Drive, replytype=testing.DriveReport
            )
        )
    else:  # the step is nested in the firmware's call, which has its own (longer) timeout
        node_id = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    with simulator.start() as simulation:
        start = time.monotonic()
        with pytest.raises(mcs.NodeTimeoutError) as info:
            simulation.get(node_id).send(testing.Drive(speed=1.0, steps=40))
        waited = time.monotonic() - start
    assert info.value.name == "cart"
    # The same words as for a process participant, and the line it was stuck on.
    assert "did not finish its step at t=0.5 s within 1 s" in str(info.value)
    assert "interrupted in step at test_host_death.py" in str(info.value)
    assert "while ctx.time >= 0.5:" in str(info.value)
    assert waited < 1.0 + 10.0  # its timeout, and a margin for a loaded machine


def test_in_process_setup_that_never_ends_times_out() -> None:
    class Endless:
        period = 0.01

        def setup(self, ctx: mcs.StepContext) -> None:
            while True:
                time.sleep(0.01)

        def step(self, ctx: mcs.StepContext) -> None:
            pass

    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(Endless, name="endless", start_timeout=0.3))
    with pytest.raises(mcs.NodeStartError, match=r"'endless' did not become ready within 0\.3 s"):
        simulator.start()


def test_in_process_step_error_names_the_component() -> None:
    class Broken:
        period = 0.01

        def setup(self, ctx: mcs.StepContext) -> None:
            pass

        def step(self, ctx: mcs.StepContext) -> None:
            if ctx.time >= 0.1:
                raise ValueError("bad state")

    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(Broken, name="broken"))
    with simulator.start() as simulation, pytest.raises(ValueError, match="bad state") as info:
        simulation.advance(1.0)
    assert info.value.__notes__ == ["in the step of component 'broken' at t=0.1 s"]
    with pytest.raises(mcs.ConfigurationError, match="start_timeout"):
        mcs.InProcessComponent(Broken, name="x", start_timeout=0)
