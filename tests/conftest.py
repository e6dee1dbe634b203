"""Shared fixtures of the test suite."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator

import pytest

# In-process pytester runs forget the modules first imported inside them; pyzmq's C extension
# cannot be imported twice (its exceptions would stop matching), so the outer session imports
# it before any inner run can.
import multicosim._local  # noqa: F401


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
