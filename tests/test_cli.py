"""The ``multicosim`` command: plain help that names defaults, errors without tracebacks."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
from pathlib import Path

import pytest

import multicosim as mcs

HELPS = [
    [],
    ["serve"],
    ["participant"],
    ["sweep"],
    ["plot"],
    ["images"],
    ["images", "build"],
    ["px4"],
    ["px4", "sitl"],
    ["px4", "launch"],
    ["ardupilot"],
    ["ardupilot", "launch"],
]


def _multicosim(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "multicosim", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, **(env or {})},
        check=False,
    )


@pytest.mark.parametrize("command", HELPS, ids=lambda c: " ".join(c) or "multicosim")
def test_help_is_plain_text_and_names_the_defaults(command: list[str]) -> None:
    result = _multicosim(*command, "--help")
    assert result.returncode == 0, result.stderr
    text = result.stdout
    assert "`" not in text, text  # no reStructuredText or Markdown
    if command == ["serve"]:
        assert "(default: 0)" in " ".join(text.split())
    if command == ["px4", "sitl"]:
        flat = " ".join(text.split())
        for default in ("(default: medium)", "(default: 1.0)", "(default: 14550)"):
            assert default in flat


def test_an_unreachable_engine_is_one_line_without_a_traceback(tmp_path: Path) -> None:
    result = _multicosim("images", "build", env={"DOCKER_HOST": f"unix://{tmp_path}/none.sock"})
    assert result.returncode == 1
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("multicosim: error: the Docker engine is not running")


def test_a_missing_debootstrap_names_the_package_to_install(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from multicosim.docker import _images

    monkeypatch.setenv("PATH", str(tmp_path))  # no debootstrap on it
    with pytest.raises(mcs.MulticosimError, match="apt-get install -y debootstrap"):
        _images.build_base("multicosim/never-built:0")


def test_px4_sitl_prints_the_ports_to_connect_to() -> None:
    ports = []
    for _ in range(2):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("127.0.0.1", 0))
            ports.append(probe.getsockname()[1])
    gcs, api = ports
    result = _multicosim(
        "px4", "sitl", "--fidelity", "low", "--speed", "50", "--duration", "1",
        "--gcs-port", str(gcs), "--api-port", str(api),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    ready = re.search(r"ready: (.*)", result.stdout)
    assert ready is not None, result.stdout
    assert ready.group(1) == f"QGroundControl on UDP {gcs}, MAVSDK on udpin://0.0.0.0:{api}"
