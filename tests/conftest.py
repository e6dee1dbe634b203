"""Shared fixtures of the test suite."""

from __future__ import annotations

import importlib
import os
import signal
from collections.abc import Iterator

import pytest

# In-process pytester runs forget the modules first imported inside them, and C extensions
# cannot be imported twice in a process (numpy refuses; pyzmq's exceptions stop matching): the
# outer session imports the ones inner runs use before any inner run can.
for _name in ("numpy", "zmq", "mujoco", "matplotlib.figure", "docker", "multicosim.local"):
    importlib.import_module(_name)

# A suite started as a background job (``cmd &`` without job control) inherits SIGINT
# ignored, and so would every program it starts: the tests that press Ctrl-C on one would
# press it for nothing. A handler here is not inherited across exec, so they get the default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture
def no_leaks() -> Iterator[None]:
    """Fail if the test leaves a child process of this interpreter running."""
    before = _children()
    yield
    left = _children() - before
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, f"processes left running: {sorted(left)}"


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
