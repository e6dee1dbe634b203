"""SIGTERM to pytest stops a run as Ctrl-C does; an unwritable artifacts directory is refused."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcs_programs import process_gone
from plugin_helpers import write_ini

SIGTERMED = """
from pathlib import Path
import pytest
import multicosim as mcs

@pytest.fixture
def marker():
    yield
    Path("torn-down").write_text("")

def test_stuck(marker, mcs_simulator):
    mcs_simulator.add(
        mcs.ProcessComponent("python -m multicosim participant multicosim.testing:Stuck")
    )
    simulation = mcs_simulator.start()
    simulation.advance(10.0)  # the participant never finishes its step at t=0.05 s

def test_never_runs():
    Path("ran").write_text("")
"""


def _stuck_pid(runs: Path) -> int | None:
    """The pid of the Stuck participant once its log says it is stuck in a step."""
    for log in runs.glob("*/stuck.log"):
        found = re.search(r"stuck at t=\S+ \(pid (\d+)\)", log.read_text())
        if found:
            return int(found.group(1))
    return None


def test_sigterm_mid_step_tears_down_like_ctrl_c(
    pytester: pytest.Pytester, reaper: list[int], isolated_runs: Path
) -> None:
    pytester.makepyfile(test_sigterm=SIGTERMED)
    child = subprocess.Popen(
        [sys.executable, "-m", "pytest", "-p", "no:xdist", "test_sigterm.py"],
        cwd=pytester.path,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        deadline = time.monotonic() + 60
        while (pid := _stuck_pid(isolated_runs)) is None and time.monotonic() < deadline:
            assert child.poll() is None, "pytest ended before the participant got stuck"
            time.sleep(0.05)
        assert pid is not None, "the participant never got stuck in its step"
        reaper.append(pid)
        child.send_signal(signal.SIGTERM)
        output, _ = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    text = output.decode()
    assert child.returncode == pytest.ExitCode.INTERRUPTED, text
    assert "KeyboardInterrupt" in text
    assert (pytester.path / "torn-down").exists(), "fixture teardown did not run"
    assert not (pytester.path / "ran").exists()
    assert process_gone(pid)
    assert list(isolated_runs.iterdir()) == []


def test_sigterm_handler_only_while_simulations_are_used(pytester: pytest.Pytester) -> None:
    # A session that never uses the plugin's simulation fixtures keeps SIGTERM's default.
    pytester.makepyfile(
        """
        import os, signal

        def test_plain():
            assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL

        def test_with_simulations(mcs_simulations):
            assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
        """
    )
    pytester.runpytest_subprocess().assert_outcomes(passed=2)


@pytest.mark.parametrize(
    ("where", "reason"),
    [
        (
            "file/inside",
            "the directory */file/inside cannot be created (*/file is not a directory)",
        ),
        (
            "/proc/mcs-artifacts",
            "the directory /proc/mcs-artifacts cannot be created (making one in /proc fails: *)",
        ),
    ],
)
def test_unwritable_artifacts_directory_is_a_usage_error(
    pytester: pytest.Pytester, where: str, reason: str
) -> None:
    (pytester.path / "file").write_text("a file, not a directory")
    pytester.makepyfile("def test_x(): pass")
    result = pytester.runpytest_subprocess(f"--mcs-artifacts={where}")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines([f"*--mcs-artifacts: {where!r} cannot hold traces*{reason}*"])
    assert not (pytester.path / "file" / "inside").exists()


def test_unwritable_artifacts_in_the_ini_file_is_a_usage_error(pytester: pytest.Pytester) -> None:
    (pytester.path / "file").write_text("")
    write_ini(pytester, mcs_artifacts="file/traces")
    pytester.makepyfile("def test_x(): pass")
    result = pytester.runpytest_subprocess()
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*mcs_artifacts (in *.ini): 'file/traces' cannot hold*"])


def test_writable_artifacts_directory_is_accepted_and_not_created(
    pytester: pytest.Pytester,
) -> None:
    pytester.makepyfile("def test_x(): pass")
    result = pytester.runpytest_subprocess("--mcs-artifacts=new/artifacts")
    result.assert_outcomes(passed=1)
    # The check probes where it would write; nothing is left behind.
    assert not (pytester.path / "new").exists()
    assert [p for p in pytester.path.iterdir() if p.name.startswith(".mcs-probe-")] == []


def test_artifacts_check_runs_as_this_user(pytester: pytest.Pytester) -> None:
    # Permission bits are checked by trying: what the effective user may do decides.
    locked = pytester.path / "locked"
    locked.mkdir(mode=0o500)
    pytester.makepyfile("def test_x(): pass")
    result = pytester.runpytest_subprocess("--mcs-artifacts=locked/a")
    if os.geteuid() == 0:  # root writes anywhere: the directory is usable
        result.assert_outcomes(passed=1)
    else:
        assert result.ret == pytest.ExitCode.USAGE_ERROR
