"""With multicosim installed, a suite that uses none of it sees nothing of it.

The plugin acts only for tests that use its fixtures or the ``fidelity`` marker, or when an
``--mcs-*`` option is given. A stand-in Docker engine (a Unix socket that counts connections)
and a run directory left by a dead process show whether a session swept; the same session with
one test of ours, and with an option, shows that the probes do see the plugin when it acts.
"""

from __future__ import annotations

import os
import socket
import subprocess
import threading
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import pytest

UNRELATED = """
def test_passes():
    assert True


def test_fails():
    assert 1 == 2, "an ordinary failure"
"""

OURS = """
def test_uses_a_multicosim_fixture(mcs_seed):
    assert mcs_seed < 0, "a failure of ours"
"""


class FakeEngine:
    """A Unix socket where a Docker client would connect: it counts and drops connections."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.connections = 0
        self._server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._server.bind(str(path))
        self._server.listen(16)
        self._server.settimeout(0.1)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                connection, _ = self._server.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            self.connections += 1
            connection.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self._server.close()


@pytest.fixture
def engine(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[FakeEngine]:
    fake = FakeEngine(tmp_path / "docker.sock")
    monkeypatch.setenv("DOCKER_HOST", f"unix://{fake.path}")
    # The inner session must not know it runs inside a test: nested sessions leave Docker alone.
    monkeypatch.delenv("PYTEST_CURRENT_TEST", raising=False)
    try:
        yield fake
    finally:
        fake.close()


@pytest.fixture
def stale_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A run directory whose host process has exited: what a sweep removes."""
    tmp = tmp_path / "tmp"
    monkeypatch.setenv("TMPDIR", str(tmp))
    run = tmp / f"multicosim-{os.getuid()}" / "runs" / "left-by-a-killed-run"
    run.mkdir(parents=True)
    gone = subprocess.Popen(["true"])
    gone.wait()
    (run / "owner").write_text(str(gone.pid))
    return run


def properties(junit: Path) -> list[tuple[str | None, str | None]]:
    root = ET.parse(junit).getroot()
    return [(p.get("name"), p.get("value")) for p in root.iter("property")]


def test_an_unrelated_suite_sees_nothing_of_multicosim(
    pytester: pytest.Pytester, engine: FakeEngine, stale_run: Path
) -> None:
    pytester.makepyfile(test_unrelated=UNRELATED)
    result = pytester.runpytest_subprocess("--junitxml=junit.xml", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, failed=1)
    text = result.stdout.str().replace(str(pytester.path), "DIR")  # its name says multicosim
    mentions = [
        line
        for line in text.splitlines()
        if "multicosim" in line.lower() and not line.startswith("plugins:")
    ]
    assert mentions == []  # no header line, no report section
    assert "replay:" not in text
    assert "an ordinary failure" in result.stdout.str()
    assert properties(pytester.path / "junit.xml") == []
    assert not (pytester.path / "mcs-artifacts").exists()
    assert stale_run.exists(), "the session swept processes"
    assert engine.connections == 0, "the session contacted the Docker engine"

    # The probes work: one test of ours makes the plugin act (for that test only).
    pytester.makepyfile(test_ours=OURS)
    result = pytester.runpytest_subprocess("--junitxml=junit.xml", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, failed=2)
    result.stdout.fnmatch_lines(["multicosim: fidelity=low placement=default seed=0 *"])
    assert result.stdout.str().count("- multicosim -") == 1
    result.stdout.fnmatch_lines(["verdict: AssertionError: a failure of ours*"])
    assert dict(properties(pytester.path / "junit.xml"))["mcs_seed"] == "0"
    assert not stale_run.exists()
    assert engine.connections > 0

    # An --mcs-* option makes it act for every test.
    result = pytester.runpytest_subprocess("--mcs-seed=5", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, failed=2)
    assert result.stdout.str().count("- multicosim -") == 2
    result.stdout.fnmatch_lines(["verdict: AssertionError: an ordinary failure*"])


def test_a_fidelity_marker_alone_makes_a_test_ours(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_marked="""
        import pytest

        @pytest.mark.fidelity("low")
        def test_marked():
            assert False, "marked"

        def test_plain():
            assert False, "plain"
        """
    )
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=2)
    assert result.stdout.str().count("- multicosim -") == 1
    result.stdout.fnmatch_lines(["verdict: AssertionError: marked*"])
