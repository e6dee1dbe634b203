"""The local backend with real processes and sockets."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
from multicosim import testing
from multicosim.local import ProcessFirmwareNode, sweep_stale_runs
from multicosim.local.rundirs import _process_run_id

CART = "python -m multicosim participant multicosim.testing:Cart"
DRIVE = "python -m multicosim serve multicosim.testing:drive --port {port}"
MISBEHAVE = "python -m multicosim serve multicosim.testing:misbehave --port {port}"

pytestmark = pytest.mark.usefixtures("no_leaks")


def _drive_report(world: str, firmware: str, steps: int = 20) -> testing.DriveReport:
    simulator = mcs.ProcessSimulator(seed=7)
    if world == "process":
        simulator.add(mcs.ProcessComponent(CART, name="cart"))
    else:
        simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    if firmware == "process":
        node_id = simulator.add(
            mcs.ProcessFirmwareComponent(
                DRIVE, name="drive", msgtype=testing.Drive, replytype=testing.DriveReport
            )
        )
        with simulator.start() as simulation:
            return simulation.get(node_id).send(testing.Drive(speed=1.5, steps=steps))
    inproc = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    with simulator.start() as simulation:
        return simulation.get(inproc).send(testing.Drive(speed=1.5, steps=steps))


def test_same_run_in_process_and_as_processes() -> None:
    reference = _drive_report("inprocess", "inprocess")
    assert reference.positions[:3] == pytest.approx([0.0, 0.075, 0.15])
    for world, firmware in [
        ("process", "process"),
        ("inprocess", "process"),
        ("process", "inprocess"),
    ]:
        assert _drive_report(world, firmware) == reference, (world, firmware)


def test_firmware_serves_until_stopped() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(
        mcs.ProcessFirmwareComponent(
            "python -m multicosim serve multicosim.testing:echo",
            msgtype=testing.Echo,
            replytype=testing.Echo,
        )
    )
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        for i in range(50):
            assert node.send(testing.Echo(text=str(i))).text == str(i)


def test_reply_without_declared_type_is_plain_data() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(
        mcs.ProcessFirmwareComponent("python -m multicosim serve multicosim.testing:echo")
    )
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        assert node.send(testing.Echo(text="hi")) == {"text": "hi", "payload": b""}
        # Without a declared type the firmware itself rejects a wrong message.
        with pytest.raises(mcs.MessageTypeError, match="echo expects Echo, got Speed"):
            node.send(testing.Speed(speed=1.0))


def test_wrong_message_type_is_rejected_before_sending() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.ProcessFirmwareComponent(DRIVE, msgtype=testing.Drive))
    with (
        simulator.start() as simulation,
        pytest.raises(mcs.MessageTypeError, match="expected a Drive"),
    ):
        simulation.get(node_id).send(testing.Echo(text="x"))  # type: ignore[arg-type]


def test_invalid_field_values_are_rejected_on_receipt() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.ProcessFirmwareComponent(DRIVE, msgtype=testing.Drive))
    with simulator.start() as simulation:
        bad = testing.Drive(speed="fast", steps=2)  # type: ignore[arg-type]
        with pytest.raises(mcs.MessageTypeError, match=r"not a valid Drive.*\$\.speed"):
            simulation.get(node_id).send(bad)


def _misbehaving(
    timeout: float = 30.0,
) -> tuple[mcs.ProcessSimulator, mcs.NodeId[mcs.ProcessFirmwareNode[testing.Misbehave, str]]]:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(
        mcs.ProcessFirmwareComponent(
            MISBEHAVE,
            name="faulty",
            msgtype=testing.Misbehave,
            replytype=str,
            timeout=timeout,
        )
    )
    return simulator, node_id


def test_handler_exception_is_a_remote_error_with_traceback() -> None:
    simulator, node_id = _misbehaving()
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        with pytest.raises(
            mcs.RemoteError, match="'faulty' raised RuntimeError: asked to raise"
        ) as info:
            node.send(testing.Misbehave(how="raise"))
        assert "Traceback" in info.value.remote_traceback
        assert node.send(testing.Misbehave(how="fine")) == "fine"  # still serving


def test_crash_names_component_exit_code_and_output() -> None:
    simulator, node_id = _misbehaving()
    simulation = simulator.start()
    with pytest.raises(mcs.NodeCrashedError) as info:
        simulation.get(node_id).send(testing.Misbehave(how="exit", code=5))
    err = info.value
    assert (err.name, err.exit_code) == ("faulty", 5)
    assert "exiting on request" in err.log_tail
    simulation.stop()  # the crash was reported once; stopping does not raise it again


def test_no_answer_is_a_timeout_with_output() -> None:
    simulator, node_id = _misbehaving(timeout=0.5)
    with simulator.start() as simulation:
        with pytest.raises(
            mcs.NodeTimeoutError, match=r"'faulty' did not answer within 0\.5 s"
        ) as info:
            simulation.get(node_id).send(testing.Misbehave(how="hang"))
        assert "serving" in info.value.log_tail


def test_crash_of_a_participant_during_a_step(tmp_path: Path) -> None:
    script = tmp_path / "dies.py"
    script.write_text(
        "import os, multicosim.testing as t\n"
        "class Dies(t.Cart):\n"
        "    def step(self, ctx):\n"
        "        if ctx.time >= 0.1:\n"
        "            print('world giving up', flush=True); os._exit(9)\n"
        "        super().step(ctx)\n"
        "from multicosim import run_participant\n"
        "run_participant(Dies())\n"
    )
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.ProcessComponent(["python", str(script)], name="world"))
    node_id = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    simulation = simulator.start()
    with pytest.raises(mcs.NodeCrashedError) as info:
        simulation.get(node_id).send(testing.Drive(speed=1.0, steps=10))
    assert (info.value.name, info.value.exit_code) == ("world", 9)
    assert "world giving up" in info.value.log_tail
    assert "t=0.1 s" in str(info.value)
    simulation.stop()


def test_command_that_exits_at_once_is_a_start_error() -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(
        mcs.ProcessComponent(
            ["python", "-c", "print('no config'); raise SystemExit(2)"], name="quick"
        )
    )
    with pytest.raises(mcs.NodeStartError, match="'quick' exited before it was ready") as info:
        simulator.start()
    assert info.value.exit_code == 2
    assert "no config" in info.value.log_tail


def test_failed_start_stops_what_was_started() -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.ProcessComponent("sleep 60", name="first", ready="started"))
    simulator.add(mcs.ProcessComponent("false", name="second"))
    with pytest.raises(mcs.NodeStartError, match="second"):
        simulator.start()
    # no_leaks checks that "first" was stopped too


def test_handshake_timeout() -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.ProcessComponent("sleep 60", name="silent", start_timeout=0.3))
    with pytest.raises(mcs.NodeStartError, match=r"did not become ready within 0\.3 s"):
        simulator.start()


def test_explicit_port_in_use_is_a_start_error() -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        simulator = mcs.ProcessSimulator()
        simulator.add(mcs.ProcessFirmwareComponent(DRIVE, port=port, name="drive"))
        with pytest.raises(mcs.NodeStartError, match="'drive' exited before it was ready") as info:
            simulator.start()
        assert "Address already in use" in info.value.log_tail


def test_explicit_free_port_is_used() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.ProcessFirmwareComponent(DRIVE, port=port))
    with simulator.start() as simulation:
        assert simulation.get(node_id).endpoint == f"tcp://127.0.0.1:{port}"


def test_process_ignoring_sigterm_is_killed() -> None:
    code = (
        "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
        "print('up', flush=True); time.sleep(60)"
    )
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(
        mcs.ProcessComponent(
            ["python", "-c", code], name="stubborn", ready="started", stop_timeout=0.3
        )
    )
    simulation = simulator.start()
    pid = simulation.get(node_id).pid
    simulation.stop()
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_logs_are_kept_per_component(tmp_path: Path) -> None:
    simulator = mcs.ProcessSimulator(run_dir=tmp_path)
    a_id = simulator.add(
        mcs.ProcessComponent(
            ["python", "-c", "print('hello from a', flush=True); import time; time.sleep(30)"],
            name="a",
            ready="started",
        )
    )
    simulator.add(mcs.ProcessFirmwareComponent(DRIVE, name="b"))
    with simulator.start() as simulation:
        logs = simulation.logs()
        assert sorted(logs) == ["a", "b"]
        deadline = time.monotonic() + 10
        while "hello from a" not in logs["a"].read_text() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert "hello from a" in simulation.get(a_id).log_tail()
    # With an explicit run_dir the logs stay after stop.
    assert "serving" in logs["b"].read_text()


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"command": ""}, "command"),
        ({"command": []}, "command"),
        ({"command": DRIVE, "port": 0}, "port"),
        ({"command": DRIVE, "port": 65536}, "port"),
        ({"command": DRIVE, "port": "5556"}, "port"),
        ({"command": DRIVE, "msgtype": "Drive"}, "msgtype"),
        ({"command": DRIVE, "timeout": 0}, "timeout"),
    ],
)
def test_bad_firmware_component_configuration(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        mcs.ProcessFirmwareComponent(**kwargs)  # type: ignore[arg-type]
    assert info.value.field == field


def test_bad_process_component_configuration() -> None:
    with pytest.raises(mcs.ConfigurationError, match="command=''"):
        mcs.ProcessComponent("")
    with pytest.raises(mcs.ConfigurationError, match="ready"):
        mcs.ProcessComponent("sleep 1", ready="soon")  # type: ignore[arg-type]
    with pytest.raises(mcs.ConfigurationError, match="seed"):
        mcs.ProcessSimulator(seed=-1)


def test_duplicate_names_and_late_adds() -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.ProcessComponent("sleep 5", name="x", ready="started"))
    with pytest.raises(mcs.ConfigurationError, match="name='x'"):
        simulator.add(mcs.ProcessComponent("sleep 5", name="x", ready="started"))
    with simulator.start():
        with pytest.raises(mcs.MulticosimError, match="after start"):
            simulator.add(mcs.ProcessComponent("sleep 5", name="y", ready="started"))
        with pytest.raises(mcs.MulticosimError, match="already started"):
            simulator.start()


def test_stopped_node_refuses_messages() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(mcs.ProcessFirmwareComponent(DRIVE, msgtype=testing.Drive))
    simulation = simulator.start()
    node = simulation.get(node_id)
    simulation.stop()
    with pytest.raises(mcs.MulticosimError, match="is stopped"):
        node.send(testing.Drive(speed=1.0, steps=1))


def test_firmware_served_in_a_thread_outside_a_simulation() -> None:
    stop = threading.Event()
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = threading.Thread(
        target=mcs.serve,
        args=(testing.echo,),
        kwargs={"port": port, "stop": stop, "environment": (None, "echo", 0)},
    )
    server.start()
    node: ProcessFirmwareNode[testing.Echo, testing.Echo] = ProcessFirmwareNode(
        "echo",
        f"tcp://127.0.0.1:{port}",
        msgtype=testing.Echo,
        replytype=testing.Echo,
        timeout=5.0,
        watch=None,
        environment=None,
        on_stop=stop.set,
    )
    try:
        pong = node.ping()
        assert (pong.name, pong.msgtype) == ("echo", "Echo")
        assert node.send(testing.Echo(text="ok", payload=b"\x00\x01")).payload == b"\x00\x01"
    finally:
        node.stop()
        server.join(5)
    assert not server.is_alive()


def test_sweep_removes_processes_of_a_killed_run(tmp_path: Path) -> None:
    dead = subprocess.Popen(["true"])
    dead.wait()
    run_dir = tmp_path / "mcs-deadbeef0000"
    run_dir.mkdir()
    (run_dir / "owner").write_text(str(dead.pid))
    leftover = subprocess.Popen(
        ["sleep", "60"], env={**os.environ, "MCS_RUN_ID": run_dir.name}, start_new_session=True
    )
    unrelated = subprocess.Popen(["sleep", "60"], start_new_session=True)
    (run_dir / "pids").write_text(f"{leftover.pid}\n{unrelated.pid}\n")
    # Until the child has exec'd, /proc shows the environment it inherited from us.
    deadline = time.monotonic() + 10
    while _process_run_id(leftover.pid) != run_dir.name and time.monotonic() < deadline:
        time.sleep(0.01)
    try:
        assert sweep_stale_runs(tmp_path) == [leftover.pid]
        assert leftover.wait(5) == -signal.SIGKILL
        assert unrelated.poll() is None  # not ours: its environment lacks the run id
        assert not run_dir.exists()
    finally:
        unrelated.kill()
        unrelated.wait()


def test_sweep_keeps_a_run_directory_being_created(tmp_path: Path) -> None:
    # Another process's sweep can come between creating a run's directory and writing its
    # owner: a directory just created is not a dead run's; one left long without an owner is.
    creating = tmp_path / "mcs-000000000001"
    creating.mkdir()
    left = tmp_path / "mcs-000000000002"
    left.mkdir()
    old = time.time() - 3600
    os.utime(left, (old, old))
    assert sweep_stale_runs(tmp_path) == []
    assert creating.is_dir()
    assert not left.exists()


def test_participant_program_needs_a_simulation() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "multicosim", "participant", "multicosim.testing:Cart"],
        capture_output=True,
        text=True,
        env={k: v for k, v in os.environ.items() if not k.startswith("MCS_")},
    )
    assert out.returncode != 0
    assert "MCS_COORDINATOR is not set" in out.stderr


def test_cli_rejects_a_bad_target() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "multicosim", "serve", "multicosim.testing:Cart"],
        capture_output=True,
        text=True,
    )
    assert out.returncode != 0
    assert "is not a firmware" in out.stderr


def test_firmware_thread_component_runs_in_lockstep() -> None:
    reference = _drive_report("inprocess", "inprocess")
    simulator = mcs.ProcessSimulator(seed=7)
    simulator.add(mcs.ProcessComponent(CART, name="cart"))
    node_id = simulator.add(
        mcs.ThreadFirmwareComponent(testing.drive, replytype=testing.DriveReport)
    )
    with simulator.start() as simulation:
        report = simulation.get(node_id).send(testing.Drive(speed=1.5, steps=20))
    assert report == reference


@pytest.mark.parametrize(
    ("command", "name"),
    [
        ("python -m multicosim serve multicosim.testing:drive --port {port}", "drive"),
        ("python -m multicosim participant multicosim.testing:Cart", "cart"),
        ("python -m mypackage.world --fast", "world"),
        ("python3 scripts/controller.py", "controller"),
        ("/usr/bin/sleep 5", "sleep"),
    ],
)
def test_default_component_names(command: str, name: str) -> None:
    assert mcs.ProcessComponent(command).name == name


class Sluggish:
    """A participant whose every step takes 20 ms of wall time: a loaded machine's pace."""

    period = 0.01

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        time.sleep(0.02)


@pytest.mark.parametrize("where", ["in-process", "thread", "process"])
def test_a_firmware_stepping_slowly_is_not_timed_out_while_the_clock_moves(where: str) -> None:
    # Its timeout is liveness: 0.3 s without the simulated clock moving. Stepping 2 simulated
    # seconds next to a sluggish participant takes 200 steps of 20 ms: longer in all than
    # the timeout, never that long between two steps. (Simulated time decides.)
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(Sluggish, name="sluggish"))
    component: Any
    if where == "in-process":
        component = mcs.InProcessFirmwareComponent(testing.misbehave, timeout=0.3)
    elif where == "thread":
        component = mcs.ThreadFirmwareComponent(testing.misbehave, replytype=str, timeout=0.3)
    else:
        component = mcs.ProcessFirmwareComponent(
            MISBEHAVE, name="misbehave", msgtype=testing.Misbehave, replytype=str, timeout=0.3
        )
    node_id = simulator.add(component)
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        assert node.send(testing.Misbehave(how="step", seconds=2.0)) == "step"
        # Between steps, the timeout still holds: a handler that stops stepping is stopped.
        with pytest.raises(mcs.NodeTimeoutError, match=r"did not answer within 0\.3 s"):
            node.send(testing.Misbehave(how="spin", seconds=5.0))
