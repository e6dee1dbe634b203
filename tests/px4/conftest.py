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
from collections.abc import Generator, Iterator
from typing import Any, cast

import pytest


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


# -- agreement: each case of PX4's suite has one outcome on both autopilots ------------------

# The outcome travels in the report (as xdist sends reports to the controller), so the run
# that judges agreement sees every case's outcomes, whichever worker flew them.
_OUTCOME = "px4-agreement"
# case -> autopilot -> "pass" / "fail", and case -> why it may differ (a module's word).
_seen: dict[str, dict[str, str]] = {}


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """Note the outcome of a case flown on an ``autopilot`` (an expected failure is a fail)."""
    report = yield
    callspec = getattr(item, "callspec", None)
    autopilot = callspec.params.get("autopilot") if callspec is not None else None
    module: Any = getattr(item, "module", None)
    if autopilot is None or not hasattr(module, "KNOWN_DIFFERENCES"):
        return report
    if report.when == "call" or (report.when == "setup" and report.outcome != "passed"):
        xfailed = report.outcome == "skipped" and hasattr(report, "wasxfail")
        if report.outcome == "skipped" and not xfailed:
            return report  # not flown (no PX4 binary): nothing to compare
        failed = report.outcome == "failed" or xfailed
        case = getattr(item, "originalname", item.name)
        known = module.KNOWN_DIFFERENCES.get(case, "")
        open_ = getattr(module, "OPEN_DIFFERENCES", {}).get(case, "")
        report.user_properties.append(
            (_OUTCOME, [case, str(autopilot), "fail" if failed else "pass", known, open_])
        )
    return report


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    for name, value in report.user_properties:
        if name == _OUTCOME:
            case, autopilot, outcome, known, open_ = cast(list[str], value)
            seen = _seen.setdefault(case, {})
            seen[autopilot] = outcome
            seen["_known"], seen["_open"] = known, open_


def _disagreements() -> list[str]:
    out = []
    for case, seen in sorted(_seen.items()):
        both = {"builtin", "sitl"} <= seen.keys()
        if both and seen["builtin"] != seen["sitl"] and not seen["_known"] and not seen["_open"]:
            out.append(f"{case}: built-in {seen['builtin']}, real PX4 {seen['sitl']}")
    return out


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Fail the run where a case's outcome differs between the built-in autopilot and real
    PX4, unless it is a known difference (with the PX4 v1.15 source that explains it) or an
    open one (measured, its cause not yet found: listed, so it is not forgotten)."""
    if hasattr(session.config, "workerinput"):
        return  # a worker sees only its own cases: the controller judges
    if _disagreements() and exitstatus == pytest.ExitCode.OK:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter: Any, exitstatus: int, config: pytest.Config) -> None:
    """Per case flown on both: built-in vs real PX4, and where they disagree."""
    seen = {c: s for c, s in _seen.items() if "sitl" in s}
    if not seen or hasattr(config, "workerinput"):
        return
    terminalreporter.section("built-in autopilot vs real PX4")
    for case, s in sorted(seen.items()):
        why = ""
        if s.get("builtin") not in (None, s["sitl"]):
            why = f" (known: {s['_known']})" if s["_known"] else ""
            why = why or (f" (open: {s['_open']})" if s["_open"] else "")
        terminalreporter.line(
            f"{case}: built-in {s.get('builtin', '-')}, real PX4 {s['sitl']}{why}"
        )
    for line in _disagreements():
        terminalreporter.line(f"DISAGREE {line}", red=True)
