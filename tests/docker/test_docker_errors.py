"""Bad input and failures of the Docker backend: each gives a clear error and leaks nothing."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from typing import Any

import pytest

import multicosim as mcs
from multicosim.docker import (
    AttachedComponent,
    ContainerComponent,
    ContainerFirmwareComponent,
    ContainerSimulator,
    EngineUnavailableError,
    ImageMissingError,
    sweep,
)
from multicosim.docker import _selftest as st

SERVE = "multicosim serve multicosim.docker._selftest:{} --host 0.0.0.0 --port {{port}}"
WORLD = "multicosim participant multicosim.docker._selftest:World"


def echo(image: str, **kw: Any) -> ContainerFirmwareComponent[st.Echo, st.EchoReply]:
    kw.setdefault("name", "echo")
    return ContainerFirmwareComponent(
        image=image, command=SERVE.format("echo"), msgtype=st.Echo, replytype=st.EchoReply, **kw
    )


def test_missing_image_says_how_to_build_and_never_pulls(engine: Any, ours: Any) -> None:
    from multicosim.docker.engine import session_id

    missing = "multicosim/does-not-exist:0.0.0"
    sim = ContainerSimulator()
    sim.add(echo(missing, name="fw"))
    with pytest.raises(ImageMissingError) as info:
        sim.start()
    err = info.value
    assert isinstance(err, mcs.NodeStartError)
    assert err.name == "fw"
    assert missing in str(err)
    assert "multicosim images build" in str(err)
    assert "never pulls" in str(err)
    assert not engine.api.images(name="multicosim/does-not-exist")
    assert ours(session=session_id()) == ([], [])  # checked before anything was created


def test_command_that_exits_at_once_is_named_with_code_and_output(
    engine: Any, image: str, ours: Any
) -> None:
    from multicosim.docker.engine import session_id

    sim = ContainerSimulator()
    sim.add(echo(image))  # started first: must be removed when the next one fails
    sim.add(
        ContainerComponent(
            image,
            ["python", "-c", "import sys; print('boom: no config', flush=True); sys.exit(3)"],
            name="quitter",
        )
    )
    with pytest.raises(mcs.NodeStartError) as info:
        sim.start()
    err = info.value
    assert err.name == "quitter"
    assert err.exit_code == 3
    assert "boom: no config" in err.log_tail
    assert "exited before it was ready" in str(err)
    assert ours(session=session_id()) == ([], [])


def test_firmware_whose_command_fails_at_once(engine: Any, image: str) -> None:
    sim = ContainerSimulator()
    sim.add(
        ContainerFirmwareComponent(
            image=image, command="multicosim serve no.such.module:fw --port {port}", name="fw"
        )
    )
    with pytest.raises(
        mcs.NodeStartError,
        match=r"crashed \(it raised ModuleNotFoundError: No module named 'no'\) before it was "
        "ready",
    ) as info:
        sim.start()
    assert info.value.name == "fw"
    assert info.value.exit_code == 1
    assert "No module named 'no'" in info.value.log_tail


def test_firmware_that_exits_while_handling_a_message(engine: Any, image: str) -> None:
    sim = ContainerSimulator()
    fw = sim.add(echo(image))
    simulation = sim.start()
    with pytest.raises(mcs.NodeCrashedError) as info:
        simulation.get(fw).send(st.Echo("bye", exit_code=7))
    assert info.value.name == "echo"
    assert info.value.exit_code == 7
    assert "exiting with 7 as asked" in info.value.log_tail
    # Stopping does not report the crash a second time (the call did), as with a process;
    # it still removes everything.
    simulation.stop()


def test_no_handshake_times_out_with_the_log_tail(engine: Any, image: str) -> None:
    sim = ContainerSimulator()
    sim.add(
        ContainerComponent(
            image,
            ["python", "-c", "import time; print('thinking', flush=True); time.sleep(60)"],
            name="silent",
            start_timeout=1.0,
        )
    )
    with pytest.raises(mcs.NodeStartError, match=r"did not become ready within 1 s") as info:
        sim.start()
    assert "thinking" in info.value.log_tail


@pytest.fixture
def busy_port() -> Iterator[int]:
    """A loopback port something on the host already listens on."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        yield sock.getsockname()[1]


def test_host_port_already_in_use(engine: Any, image: str, busy_port: int) -> None:
    sim = ContainerSimulator()
    sim.add(echo(image, host_port=busy_port))
    with pytest.raises(mcs.NodeStartError, match=rf"127\.0\.0\.1:{busy_port} is already in use"):
        sim.start()


def test_firmware_bound_to_container_loopback_is_explained(engine: Any, image: str) -> None:
    sim = ContainerSimulator()
    sim.add(
        ContainerFirmwareComponent(
            image=image,
            command="multicosim serve multicosim.docker._selftest:echo --port {port}",
            name="hidden",
            start_timeout=2.0,
        )
    )
    with pytest.raises(mcs.NodeStartError, match=r"--host 0\.0\.0\.0") as info:
        sim.start()
    assert "serving Firmware('echo'" in info.value.log_tail


def test_message_of_the_wrong_type(engine: Any, image: str) -> None:
    sim = ContainerSimulator()
    typed = sim.add(echo(image))
    untyped = sim.add(
        ContainerFirmwareComponent[Any, Any](image=image, command=SERVE.format("echo"), name="raw")
    )
    with sim.start() as simulation:
        with pytest.raises(mcs.MessageTypeError, match="Echo"):
            simulation.get(typed).send(st.Mission(speed=1.0))  # type: ignore[arg-type]
        # Without a declared type the firmware itself rejects it.
        with pytest.raises(mcs.MessageTypeError, match="echo expects Echo, got Mission"):
            simulation.get(untyped).send(st.Mission(speed=1.0))
        assert simulation.get(untyped).send(st.Echo("ok"))["text"] == "ok"


def test_engine_not_running(monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> None:
    monkeypatch.setenv("DOCKER_HOST", f"unix://{tmp_path}/no-engine.sock")
    sim = ContainerSimulator()
    sim.add(echo("multicosim/runtime:0.1.0"))
    with pytest.raises(EngineUnavailableError, match="not running") as info:
        sim.start()
    assert "dockerd" in str(info.value)
    assert isinstance(info.value, mcs.MulticosimError)
    report = sweep()
    assert report.skipped is not None
    assert "not running" in report.summary()


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: ContainerComponent("", "true"), "image"),
        (lambda: ContainerComponent("a b", "true"), "image"),
        (lambda: ContainerComponent("img", ""), "command"),
        (lambda: ContainerComponent("img", "true", ports=[0]), "port"),
        (lambda: ContainerComponent("img", "true", ports=["80/sctp"]), "port"),
        (lambda: ContainerComponent("img", "true", ports=80), "ports"),  # type: ignore[arg-type]
        (lambda: ContainerComponent("img", "true", ready="soon"), "ready"),  # type: ignore[arg-type]
        (lambda: ContainerComponent("img", "true", env={"A": 1}), "env"),  # type: ignore[dict-item]
        (lambda: ContainerComponent("img", "true", stop_timeout=0), "stop_timeout"),
        (lambda: ContainerFirmwareComponent(image="img", command="x", port=0), "port"),
        (lambda: ContainerFirmwareComponent(image="img", command="x", port=True), "port"),
        (
            lambda: ContainerFirmwareComponent(image="img", command="x", host_port=70000),
            "host_port",
        ),
        (lambda: ContainerFirmwareComponent(image="img", command="x", msgtype=3), "msgtype"),  # type: ignore[arg-type]
        (lambda: ContainerFirmwareComponent(image="img", command="x", timeout=-1), "timeout"),
        (lambda: AttachedComponent(mcs.ProcessComponent("true"), []), "host"),  # type: ignore[arg-type]
        (
            lambda: AttachedComponent(
                ContainerComponent("img", "a"),
                ContainerComponent("img", "b"),  # type: ignore[arg-type]
            ),
            "attached",
        ),
        (
            lambda: AttachedComponent(
                ContainerComponent("img", "a"), [ContainerComponent("img", "b", ports=[1])]
            ),
            "ports",
        ),
        (
            lambda: AttachedComponent(
                ContainerComponent("img", "a", name="x"), [ContainerComponent("img", "b", name="x")]
            ),
            "name",
        ),
        (lambda: ContainerComponent("img", "a", mounts={"relative": "/x"}), "mounts"),
        (lambda: ContainerComponent("img", "a", mounts={"/no/such/dir": "/x"}), "mounts"),
        (lambda: ContainerComponent("img", "a", mounts={"/tmp": "inside"}), "mounts"),
        (lambda: ContainerComponent("img", "a", mounts={"/tmp": "/a:b"}), "mounts"),
        (lambda: ContainerComponent("img", "a", mounts=["/tmp"]), "mounts"),  # type: ignore[arg-type]
        (lambda: ContainerSimulator(seed=-1), "seed"),
        (lambda: ContainerSimulator(realtime=0), "realtime"),
    ],
)
def test_invalid_configuration_is_rejected_before_anything_starts(make: Any, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        make()
    assert info.value.field == field


def test_names_must_be_unique_across_attached_groups() -> None:
    sim = ContainerSimulator()
    sim.add(ContainerComponent("img", "a", name="world"))
    group = AttachedComponent(
        ContainerComponent("img", "a", name="host"), [ContainerComponent("img", "b", name="world")]
    )
    with pytest.raises(mcs.ConfigurationError, match="world"):
        sim.add(group)


def test_default_names_come_from_the_program() -> None:
    assert ContainerComponent("img", WORLD).name == "World"
    assert (
        ContainerFirmwareComponent(image="img", command=SERVE.format("controller")).name
        == "controller"
    )
    assert ContainerComponent("img", "/usr/bin/gz sim").name == "gz"
    assert ContainerComponent("reg/world:1", "python -m world").name == "world"
