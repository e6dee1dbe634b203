"""Fixtures for testing the pytest plugin through ``pytester``."""

from __future__ import annotations

import contextlib
import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcs_programs import process_gone
from plugin_helpers import write_ini

from pytest_multicosim.px4 import RealPX4

PROGRAMS = Path(__file__).with_name("mcs_programs.py")


@pytest.fixture(autouse=True)
def inner_ini(pytester: pytest.Pytester) -> Path:
    """Every inner run gets a strict pytest.ini (tests may overwrite it)."""
    return write_ini(pytester)


@pytest.fixture
def programs(pytester: pytest.Pytester) -> Path:
    """Copy the component programs next to the inner test files (importable as mcs_programs)."""
    return pytester.makepyfile(mcs_programs=PROGRAMS.read_text())


@pytest.fixture
def isolated_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Give child processes their own temporary directory, hence their own runs directory.

    Sweeps started by parallel sessions then never touch (or clean up for) this test's runs.
    Returns the runs directory the children use.
    """
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    return tmp / f"multicosim-{os.getuid()}" / "runs"


@pytest.fixture
def reaper() -> Iterator[list[int]]:
    """Pids the test expects to be gone; any still running at teardown is killed (no leaks)."""
    pids: list[int] = []
    yield pids
    for pid in pids:
        if not process_gone(pid, timeout=0):
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(pid, signal.SIGKILL)


@pytest.fixture(scope="session")
def session_px4(request: pytest.FixtureRequest) -> RealPX4:
    """The real PX4 this session names, read before ``pytester`` hides the firmware settings
    from inner runs."""
    from pytest_multicosim.px4 import real_px4

    return real_px4(request.config)
