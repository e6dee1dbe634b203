"""Component programs used by the plugin tests, run as real local processes.

The tests copy this module next to the test files that ``pytester`` writes, so the inner
pytest runs and their component processes import it as ``mcs_programs``. Component
processes find it through ``PYTHONPATH`` (see :data:`HERE`).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import multicosim as mcs

HERE = str(Path(__file__).resolve().parent)

# A component started with this variable appends its pid to the file it names as soon as it
# imports this module, so a test learns the pids of components even when start() fails.
PID_FILE_VAR = "MCS_TEST_PID_FILE"


def _record_pid() -> None:
    path = os.environ.get(PID_FILE_VAR)
    if path:
        with open(path, "a") as f:
            f.write(f"{os.getpid()}\n")


_record_pid()


class Req(mcs.Message):
    """A request: a number to echo, optional text to print, wall seconds to stall."""

    n: int
    say: str = ""
    stall: float = 0.0
    fail: bool = False


class Rep(mcs.Message):
    """The answer: the number, the firmware's pid and the simulated time it answered at."""

    n: int
    pid: int
    time: float


@mcs.firmware(msgtype=Req, period=0.01)
def echo(msg: Req, ctx: mcs.FirmwareContext) -> Rep:
    """Answer at once (optionally printing, stalling in wall time, or raising)."""
    if msg.say:
        print(msg.say, flush=True)
    if msg.stall:
        time.sleep(msg.stall)
    if msg.fail:
        raise RuntimeError(f"asked to fail on {msg.n}")
    return Rep(n=msg.n, pid=os.getpid(), time=ctx.time)


@mcs.firmware(msgtype=Req, period=0.01)
def stepper(msg: Req, ctx: mcs.FirmwareContext) -> Rep:
    """Advance the simulated clock ``msg.n`` periods, then answer."""
    for _ in range(msg.n):
        ctx.step()
    return Rep(n=msg.n, pid=os.getpid(), time=ctx.time)


def env(pid_file: str | os.PathLike[str] | None = None) -> dict[str, str]:
    """The environment a component process needs to import this module."""
    values = {"PYTHONPATH": os.pathsep.join([HERE, os.environ.get("PYTHONPATH", "")])}
    if pid_file is not None:
        values[PID_FILE_VAR] = str(pid_file)
    return values


def echo_component(
    name: str = "echo", pid_file: str | os.PathLike[str] | None = None
) -> mcs.ProcessFirmwareComponent[Req, Rep]:
    """The ``echo`` firmware in its own process, on a free port."""
    return mcs.ProcessFirmwareComponent(
        "python -m multicosim serve mcs_programs:echo --port {port}",
        name=name,
        env=env(pid_file),
        msgtype=Req,
        replytype=Rep,
        timeout=30.0,
    )


def stepper_component(name: str = "stepper") -> mcs.ProcessFirmwareComponent[Req, Rep]:
    """The ``stepper`` firmware in its own process, on a free port."""
    return mcs.ProcessFirmwareComponent(
        "python -m multicosim serve mcs_programs:stepper --port {port}",
        name=name,
        env=env(),
        msgtype=Req,
        replytype=Rep,
        timeout=30.0,
    )


def failing_component(name: str = "broken") -> mcs.ProcessComponent:
    """A component that prints a line and exits with code 3 before its handshake."""
    return mcs.ProcessComponent(
        [sys.executable, "-c", "import sys; print('broken: no config'); sys.exit(3)"],
        name=name,
        env=env(),
        start_timeout=20.0,
    )


def sleeper_component(name: str = "sleeper") -> mcs.ProcessComponent:
    """An arbitrary command that never joins the simulation and never exits on its own."""
    return mcs.ProcessComponent(
        [sys.executable, "-c", "import time; time.sleep(600)"], name=name, ready="started"
    )


def process_gone(pid: int, timeout: float = 10.0) -> bool:
    """Wait until ``pid`` no longer runs (a zombie counts as gone); False on timeout."""
    deadline = time.monotonic() + timeout
    while True:
        if not _running(pid):
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True  # no procfs: os.kill said it exists
    # The state follows the parenthesised command name; Z (zombie) and X (dead) have exited.
    return stat.rpartition(")")[2].split()[0] not in ("Z", "X")
