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
    ["ardupilot", "sitl"],
    ["ardupilot", "launch"],
]

DATA = Path(__file__).parent / "data"


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


def test_px4_sitl_flies_a_plan_with_a_parameter_file_and_says_how_it_went() -> None:
    result = _multicosim(
        "px4", "sitl", "--fidelity", "low", "--speed", "100",
        "--plan", str(DATA / "survey_site.plan"), "--params", str(DATA / "slow_climb_px4.txt"),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("waypoints reached: 0 at ")
    assert ", 2 at " in lines[0]
    assert "autopilot: Item 4: IMAGE_START_CAPTURE has no effect" in lines
    assert lines[-1].startswith("mission completed in ")


def test_px4_sitl_refuses_a_bad_plan_in_one_line(tmp_path: Path) -> None:
    plan = tmp_path / "survey.plan"
    plan.write_text(
        (DATA / "survey_site.plan").read_text().replace('"command": 2000', '"command": 31999')
    )
    result = _multicosim("px4", "sitl", "--fidelity", "low", "--plan", str(plan))
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "mission.items[4].command=31999" in lines[0]
    assert "a command MAVLink defines" in lines[0]


def test_a_parameter_file_of_no_known_format_is_one_line(tmp_path: Path) -> None:
    params = tmp_path / "vehicle.params"
    params.write_text("MPC_XY_CRUISE: 3\n")
    result = _multicosim(
        "px4", "sitl", "--fidelity", "low", "--duration", "1", "--params", str(params)
    )
    assert result.returncode == 1
    assert f"{params}: line 1='MPC_XY_CRUISE: 3'" in result.stderr
    assert "Traceback" not in result.stderr


def test_ardupilot_sitl_flies_a_plan(ardupilot_dir: str) -> None:
    result = _multicosim(
        "ardupilot", "sitl", "--plan", str(DATA / "survey_site.plan"),
        "--params", str(DATA / "slow_climb_copter.csv"),
        "--firmware-dir", ardupilot_dir, "--speed", "50",
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    assert "autopilot: Mission: 5 ImageStartCapture" in result.stdout.splitlines()
    assert result.stdout.splitlines()[-1].startswith("mission completed in ")
