"""Shared fixtures of the test suite."""

from __future__ import annotations

import functools
import importlib
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

# In-process pytester runs forget the modules first imported inside them, and C extensions
# cannot be imported twice in a process (numpy refuses; pyzmq's exceptions stop matching), nor
# may a class be (px4.SITL made from a module imported again is no px4.SITL to the scenario
# that kept the first): the outer session imports the ones inner runs use before any can.
for _name in (
    *("numpy", "zmq", "mujoco", "matplotlib.figure", "docker", "multicosim.local"),
    *("multicosim.px4.scenario", "multicosim.ardupilot"),
):
    importlib.import_module(_name)

# A suite started as a background job (``cmd &`` without job control) inherits SIGINT
# ignored, and so would every program it starts: the tests that press Ctrl-C on one would
# press it for nothing. A handler here is not inherited across exec, so they get the default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_configure(config: pytest.Config) -> None:
    from px4_agreement import Agreement

    config.pluginmanager.register(Agreement(), "px4-agreement")


@pytest.fixture
def no_leaks() -> Iterator[None]:
    """Fail if the test leaves a child process of this interpreter running."""
    before = _children()
    yield
    left = _children() - before
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, f"processes left running: {sorted(left)}"


def _own_runs() -> set[Path]:
    """The run directories this process owns (by the owner record a run starts with)."""
    from multicosim.local import runs_directory

    me = str(os.getpid())
    found = set()
    for run_dir in runs_directory().glob("mcs-*"):
        try:
            owner = (run_dir / "owner").read_text().split()
        except OSError:
            continue
        if owner and owner[0] == me:
            found.add(run_dir)
    return found


def _ours(engine: Any, **label: str) -> tuple[list[str], list[str]]:
    filters = {"label": [f"multicosim.{k}={v}" for k, v in label.items()]}
    containers = [c["Names"][0] for c in engine.api.containers(all=True, filters=filters)]
    networks = [n["Name"] for n in engine.api.networks(filters=filters)]
    return containers, networks


Ours = Callable[..., tuple[list[str], list[str]]]


@pytest.fixture
def ours() -> Ours:
    """``ours(run=ID)``: names of containers and networks with those multicosim labels."""
    from multicosim.docker.engine import client

    return functools.partial(_ours, client())


@pytest.fixture
def no_docker_leak_check() -> Callable[[], None]:
    """A check that nothing this process created in Docker remains (swept, then failed)."""

    def check() -> None:
        from multicosim.docker import sweep
        from multicosim.docker.engine import client, session_id

        left = _ours(client(), session=session_id())
        if left != ([], []):
            sweep(only_current_process=True)
            pytest.fail(f"left behind: containers {left[0]}, networks {left[1]}")

    return check


@pytest.fixture
def nothing_left(no_leaks: None, no_docker_leak_check: Callable[[], None]) -> Iterator[None]:
    """Fail if the test leaves a process, a run directory or (where it used Docker) a
    container or network running or present."""
    runs = _own_runs()
    yield
    left = _own_runs() - runs
    for run_dir in left:
        shutil.rmtree(run_dir, ignore_errors=True)
    assert not left, f"run directories left: {sorted(map(str, left))}"
    if "multicosim.docker.engine" in sys.modules:
        no_docker_leak_check()


def _children() -> set[int]:
    me = os.getpid()
    found = set()
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        state, ppid = fields[0], int(fields[1])
        if ppid == me and state != "Z":
            found.add(int(entry))
    return found


# CI names the real firmware in the environment; an inner session that checks its outcomes
# must see only what the test itself gives it.
_FIRMWARE_SETTINGS = ("MCS_PX4_", "MCS_ARDUPILOT_")


@pytest.fixture(scope="session")
def inner_env() -> dict[str, str]:
    """This process's environment without the real-firmware settings (for inner sessions)."""
    return {k: v for k, v in os.environ.items() if not k.startswith(_FIRMWARE_SETTINGS)}


@pytest.fixture
def pytester(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> pytest.Pytester:
    """pytest's pytester, its inner sessions kept from this run's real-firmware settings."""
    for name in list(os.environ):
        if name.startswith(_FIRMWARE_SETTINGS):
            monkeypatch.delenv(name)
    return pytester


@pytest.fixture(scope="session")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The documentation site, built as CI builds it (strict: a warning fails it)."""
    site = tmp_path_factory.mktemp("site")
    build = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=Path(__file__).resolve().parents[1],
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=900,
    )
    assert build.returncode == 0, build.stderr[-3000:]
    return site
