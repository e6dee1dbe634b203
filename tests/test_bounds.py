"""Values that would fail only once processes run are refused up front, naming the field."""

from __future__ import annotations

import math
import os
import re
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
import zmq

import multicosim as mcs
import multicosim.rover as rover
from multicosim import testing
from multicosim.local import rundirs as _rundirs
from multicosim.physics import WorldConfig

pytestmark = pytest.mark.usefixtures("no_leaks")


def _refused(call: object, field: str, value_text: str, allowed: str) -> None:
    assert callable(call)
    with pytest.raises(mcs.ConfigurationError) as info:
        call()
    message = str(info.value)
    assert info.value.field == field
    assert f"{field}={value_text}" in message, message
    assert allowed in message, message


@pytest.mark.parametrize(
    ("kwargs", "field", "value", "allowed"),
    [
        ({"timestep": 1e-9}, "timestep", "1e-09", "0.0001 <= timestep <= 0.1 s"),
        ({"timestep": 0.5}, "timestep", "0.5", "0.0001 <= timestep <= 0.1 s"),
        ({"iterations": 10**10}, "iterations", "10000000000", "an integer in 1..1000"),
        ({"iterations": 0}, "iterations", "0", "an integer in 1..1000"),
    ],
)
def test_world_config_bounds(
    kwargs: dict[str, float], field: str, value: str, allowed: str
) -> None:
    _refused(lambda: WorldConfig(**kwargs), field, value, allowed)  # type: ignore[arg-type]


def test_world_config_limits_are_accepted() -> None:
    assert WorldConfig(timestep=1e-4, period=0.01).steps_per_period == 100
    assert WorldConfig(iterations=1000).iterations == 1000


@pytest.mark.parametrize(
    ("field", "value", "allowed"),
    [
        ("distance", 1e12, "0 <= distance <= 10000 m"),
        ("final_distance", 10_000.5, "0 <= final_distance <= 10000 m"),
        ("wait", 3601.0, "0 <= wait <= 3600 s"),
        ("timeout", 1e12, "0 < timeout <= 3600 s"),
        ("turn_timeout", math.inf, "0 < turn_timeout <= 3600 s"),
        ("abort_at", 7200.0, "None or 0 <= abort_at <= 3600 s"),
    ],
)
def test_rover_mission_bounds(field: str, value: float, allowed: str) -> None:
    _refused(
        lambda: rover.Mission(speed=5.0, **{field: value}),
        field,
        repr(value),
        allowed,
    )
    assert rover.Mission(speed=5.0, distance=rover.MAX_DISTANCE, timeout=rover.MAX_MISSION_TIME)


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: mcs.ProcessSimulator(step_timeout=0), "step_timeout"),
        (lambda: mcs.ProcessSimulator(step_timeout=math.inf), "step_timeout"),
        (lambda: mcs.ProcessSimulator(step_timeout=True), "step_timeout"),
        (lambda: mcs.ProcessSimulator(realtime=1e-9), "realtime"),
        (lambda: mcs.ProcessSimulator(realtime=math.inf), "realtime"),
        (lambda: mcs.ProcessFirmwareComponent("x", timeout=math.inf), "timeout"),
        (lambda: mcs.ProcessComponent("x", start_timeout=math.nan), "start_timeout"),
        (lambda: mcs.ProcessComponent("x", memory="lots"), "memory"),
        (lambda: mcs.ProcessComponent("x", memory=1 << 20), "memory"),  # no interpreter fits
        (lambda: mcs.ProcessFirmwareComponent("x", memory=True), "memory"),
        (lambda: mcs.InProcessFirmwareComponent(testing.echo, timeout=-1.0), "timeout"),
    ],
)
def test_simulator_and_component_settings(call: object, field: str) -> None:
    assert callable(call)
    with pytest.raises(mcs.ConfigurationError) as info:
        call()
    assert info.value.field == field


def test_step_timeout_is_a_setting() -> None:
    simulator = mcs.ProcessSimulator(step_timeout=0.5)
    simulator.add(mcs.ProcessComponent("python -m multicosim participant multicosim.testing:Stuck"))
    with simulator.start() as simulation, pytest.raises(mcs.NodeTimeoutError) as info:
        simulation.advance(1.0)
    assert info.value.name == "stuck"
    assert "did not finish its step at t=0.05 s within 0.5 s" in str(info.value)
    assert "stuck at t=0.05" in info.value.log_tail


# -- the serve command's port -------------------------------------------------------------


@pytest.mark.parametrize("port", ["99999", "65536", "-5", "http"])
def test_serve_refuses_ports_that_would_wrap(port: str) -> None:
    out = subprocess.run(
        [sys.executable, "-m", "multicosim", "serve", "multicosim.testing:echo", "--port", port],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2
    assert f"argument --port: {port!r} is not a port: expected 1..65535" in out.stderr


def test_serve_api_refuses_a_bad_port() -> None:
    with pytest.raises(mcs.ConfigurationError, match=r"port=70000 is invalid"):
        mcs.serve(testing.echo, port=70000, environment=(None, "echo", 0))


@pytest.mark.parametrize("fixed", [False, True])
def test_serve_logs_the_port_it_bound(fixed: bool) -> None:
    port = 0
    if fixed:
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
    command = [sys.executable, "-m", "multicosim", "serve", "multicosim.testing:echo"]
    server = subprocess.Popen(
        [*command, "--port", str(port)],
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        assert server.stderr is not None
        line = server.stderr.readline()
        found = re.search(r"serving .* on tcp://127\.0\.0\.1:(\d+)$", line.strip())
        assert found, line
        bound = int(found.group(1))
        if fixed:
            assert bound == port
        # The port in the log is the one that answers.
        node: mcs.ProcessFirmwareNode[testing.Echo, testing.Echo] = mcs.ProcessFirmwareNode(
            "echo",
            f"tcp://127.0.0.1:{bound}",
            msgtype=testing.Echo,
            replytype=testing.Echo,
            timeout=30.0,
            watch=None,
            environment=None,
            on_stop=lambda: None,
            zctx=zmq.Context.instance(),
        )
        try:
            assert node.send(testing.Echo(text="here")).text == "here"
        finally:
            node.stop()
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(30)
        if server.stderr is not None:
            server.stderr.close()


# -- the runs directory -------------------------------------------------------------------


@pytest.fixture
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A temporary directory standing in for the system's (for runs_directory)."""
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    return tmp_path / f"multicosim-{os.getuid()}"


def test_runs_directory_is_private(private_tmp: Path) -> None:
    runs = _rundirs.runs_directory()
    assert runs == private_tmp / "runs"
    for path in (private_tmp, runs):
        info = os.lstat(path)
        assert (stat.S_IMODE(info.st_mode), info.st_uid) == (0o700, os.getuid())


def test_runs_directory_readable_by_others_is_made_private(private_tmp: Path) -> None:
    private_tmp.mkdir(mode=0o755)
    os.chmod(private_tmp, 0o755)
    _rundirs.runs_directory()
    assert stat.S_IMODE(os.lstat(private_tmp).st_mode) == 0o700


@pytest.mark.parametrize("problem", ["writable by others", "a symbolic link", "another owner"])
def test_runs_directory_someone_else_could_tamper_with_is_refused(
    private_tmp: Path, tmp_path: Path, problem: str
) -> None:
    if problem == "writable by others":
        private_tmp.mkdir()
        os.chmod(private_tmp, 0o777)
        expected = "can be written by other users (mode 777)"
    elif problem == "a symbolic link":
        elsewhere = tmp_path / "elsewhere"
        elsewhere.mkdir(mode=0o700)
        private_tmp.symlink_to(elsewhere)
        expected = "is not a directory (a symbolic link or a file)"
    else:
        if os.geteuid() != 0:
            pytest.skip("giving a directory to another user needs root")
        private_tmp.mkdir(mode=0o700)
        os.chown(private_tmp, 65534, 65534)
        expected = "belongs to uid 65534"
    with pytest.raises(mcs.MulticosimError, match=re.escape(expected)):
        _rundirs.runs_directory()
    with pytest.raises(mcs.MulticosimError, match="refusing to keep runs"):
        mcs.ProcessSimulator().start()


# -- the sweep and pid reuse --------------------------------------------------------------


def _sleeper(run_id: str | None = None) -> subprocess.Popen[bytes]:
    env = {**os.environ, "MCS_RUN_ID": run_id} if run_id else dict(os.environ)
    return subprocess.Popen(["sleep", "60"], env=env, start_new_session=True)


def test_sweep_kills_only_the_very_processes_a_dead_run_started(tmp_path: Path) -> None:
    dead = subprocess.Popen(["true"])
    dead.wait()
    run_dir = tmp_path / "mcs-0123456789ab"
    run_dir.mkdir()
    (run_dir / "owner").write_text(f"{dead.pid} 1 {_rundirs.boot_id()}\n")
    ours = _sleeper()
    # A process that now has a pid the run once recorded: its start time differs.
    reused = _sleeper()
    _rundirs.record_process(run_dir, ours.pid)
    with open(run_dir / "pids", "a") as f:
        f.write(f"{reused.pid} 1 {_rundirs.boot_id()}\n")
    try:
        assert _rundirs.sweep_stale_runs(tmp_path) == [ours.pid]
        assert ours.wait(10) == -signal.SIGKILL
        assert reused.poll() is None  # same pid as recorded, another process: left alone
        assert not run_dir.exists()
    finally:
        for proc in (ours, reused):
            proc.kill()
            proc.wait()


def test_sweep_leaves_runs_of_a_live_host_alone(tmp_path: Path) -> None:
    run_dir = tmp_path / "mcs-live00000000"
    run_dir.mkdir()
    (run_dir / "owner").write_text(
        f"{os.getpid()} {_rundirs.start_time(os.getpid())} {_rundirs.boot_id()}\n"
    )
    child = _sleeper()
    _rundirs.record_process(run_dir, child.pid)
    try:
        assert _rundirs.sweep_stale_runs(tmp_path) == []
        assert child.poll() is None
        assert run_dir.exists()
    finally:
        child.kill()
        child.wait()


def test_sweep_finds_a_group_whose_leader_has_exited(tmp_path: Path) -> None:
    dead = subprocess.Popen(["true"])
    dead.wait()
    run_dir = tmp_path / "mcs-group0000000"
    run_dir.mkdir()
    (run_dir / "owner").write_text(f"{dead.pid} 1 {_rundirs.boot_id()}\n")
    # A shell (the group's leader) that leaves a child behind and exits.
    leader = subprocess.Popen(
        ["sh", "-c", "sleep 60 & echo $!"],
        env={**os.environ, "MCS_RUN_ID": run_dir.name},
        stdout=subprocess.PIPE,
        start_new_session=True,
    )
    assert leader.stdout is not None
    child = int(leader.stdout.readline())
    leader.wait(10)
    leader.stdout.close()
    # Recorded when it started; its start time no longer matches anything.
    (run_dir / "pids").write_text(f"{leader.pid} 1 {_rundirs.boot_id()}\n")
    try:
        assert _rundirs.sweep_stale_runs(tmp_path) == [leader.pid]
        deadline = time.monotonic() + 10
        while _rundirs.start_time(child) is not None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert _rundirs.start_time(child) is None, "the group's survivor was not killed"
    finally:
        if _rundirs.start_time(child) is not None:
            os.kill(child, signal.SIGKILL)
