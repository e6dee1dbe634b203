"""Helpers for the PX4 tests: a standalone SITL process on free loopback ports."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator

import pytest

from multicosim.local.processes import before_exec


def free_udp_port() -> int:
    """A UDP port that was free a moment ago on 127.0.0.1."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def udp_port() -> int:
    """A free loopback UDP port."""
    return free_udp_port()


@pytest.fixture
def sitl() -> object:
    """Context-manager factory: ``with sitl(*args) as proc`` runs a standalone SITL."""
    return sitl_process


@contextlib.contextmanager
def sitl_process(
    *args: str, timeout: float = 30.0, ready: str = "ready"
) -> Iterator[subprocess.Popen[bytes]]:
    """``python -m multicosim px4 sitl ARGS`` in its own session; killed (group) on exit.

    It is ready when its output matches ``ready`` (the match is ``proc.ready``).
    """
    with tempfile.TemporaryFile() as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "multicosim", "px4", "sitl", *args],
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            # It dies with pytest even where pytest is killed before this fixture's teardown.
            preexec_fn=before_exec(None),
        )
        try:
            deadline = time.monotonic() + timeout
            while True:
                out.seek(0)
                seen = out.read().decode(errors="replace")
                match = re.search(ready, seen)
                if match:
                    proc.ready = match  # type: ignore[attr-defined]
                    break
                if proc.poll() is not None or time.monotonic() > deadline:
                    pytest.fail(f"SITL did not start (exit {proc.poll()}):\n{seen}")
                time.sleep(0.05)
            yield proc
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


@pytest.fixture
def sitl_thread() -> object:
    """Context-manager factory: ``with sitl_thread(port, fidelity, speed)`` runs one in-process."""
    return sitl_in_thread


@contextlib.contextmanager
def sitl_in_thread(port: int, fidelity: str, speed: float) -> Iterator[None]:
    """The autopilot and its world in a thread (``run_sitl``), linked to UDP ``port``."""
    from multicosim.mavlink.udp import Link
    from multicosim.px4.standalone import run_sitl

    stop, ready = threading.Event(), threading.Event()
    errors: list[BaseException] = []

    def run() -> None:
        try:
            run_sitl(
                fidelity=fidelity,  # type: ignore[arg-type]
                speed=speed,
                links=[Link(port)],
                stop=stop,
                on_ready=lambda _: ready.set(),
            )
        except BaseException as exc:  # reported by the test
            errors.append(exc)
            ready.set()

    thread = threading.Thread(target=run, name="sitl")
    thread.start()
    try:
        assert ready.wait(20), "SITL did not start"
        assert not errors, errors
        yield
    finally:
        stop.set()
        thread.join(20)
    assert not thread.is_alive(), "SITL thread did not stop"
    assert not errors, errors
