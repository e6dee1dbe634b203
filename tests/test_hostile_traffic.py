"""Hostile traffic on a live simulation's ZeroMQ ports changes nothing.

Against a medium-fidelity rover (the MuJoCo world and the FSA controller as processes):
random TCP bytes, frames that are not MessagePack, MessagePack of the wrong shape,
multi-frame messages, unknown and impersonated identities, and well-formed protocol frames
from outsiders (a hello, sensor data, a mission) are sent to the coordinator and to the
controller's firmware port, before and while missions run. Every run must give the
trajectories of an undisturbed run, and no outsider may take part.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import socket
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import msgspec
import pytest
import zmq
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import multicosim.rover as rover
from multicosim.core import wire

pytestmark = pytest.mark.usefixtures("no_leaks")

MISSIONS = (
    rover.Mission(speed=3.0, wait=0.5, distance=4.0, final_distance=4.0),
    rover.Mission(speed=5.0, wait=0.2, distance=2.0, final_distance=3.0),
)
TARGETS = ("coordinator", "firmware")
NAMES = (b"world", b"controller")  # the run's component names, as an impostor would guess


@contextlib.contextmanager
def live_rover() -> Iterator[Any]:
    """A medium-fidelity rover simulation (world and controller are processes)."""
    with rover.Rover(fidelity="medium", seed=3).start() as simulation:
        yield simulation


def endpoints(simulation: Any) -> dict[str, str]:
    """The ports an attacker aims at: the coordinator's and the controller firmware's."""
    return {
        "coordinator": simulation.simulation.environment.coordinator.address,
        "firmware": simulation.controller.endpoint,
    }


def plan_of(missions: int) -> list[rover.Mission]:
    """``missions`` missions, taken in turn from MISSIONS."""
    return [MISSIONS[i % len(MISSIONS)] for i in range(missions)]


def fly(simulation: Any, missions: Sequence[rover.Mission] = MISSIONS) -> list[Any]:
    """The missions, one after the other, on one simulation."""
    return [simulation.controller.send(m) for m in missions]


@functools.cache
def reference(missions: int = len(MISSIONS)) -> tuple[rover.Trajectory, ...]:
    """What an undisturbed run of ``plan_of(missions)`` gives."""
    with live_rover() as simulation:
        return tuple(fly(simulation, plan_of(missions)))


# -- what an attacker sends -------------------------------------------------------------------

# Well-formed protocol frames an outsider could forge: joining the lockstep, publishing a
# position (sensor data into a safety test), starting a mission, probing a firmware.
_POSITION = msgspec.msgpack.encode(
    rover.Position(time=0.0, x=50.0, y=50.0, z=0.0, latitude=0.0, longitude=0.0, altitude=0.0)
)
FORGED = (
    wire.encoder.encode(wire.Hello("world", 10_000_000, False, ["rover/command"], 1)),
    wire.encoder.encode(wire.Hello("intruder", 10_000_000, True, ["rover/position"], 1)),
    wire.encoder.encode(wire.Activate(["rover/position"])),
    wire.encoder.encode(wire.Yield(None, [("rover/position", _POSITION)], [])),
    wire.encoder.encode(wire.Yield(10**9, [("rover/abort", b"\x80")], ["rover/command"])),
    wire.encoder.encode(
        wire.Call(1, "Mission", msgspec.msgpack.encode(rover.Mission(speed=9.0)), 0)
    ),
    wire.encoder.encode(wire.Ping(7)),
)

msgpack_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64 - 1)
    | st.floats()
    | st.text(max_size=20)
    | st.binary(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=12,
)
frames = st.one_of(
    st.binary(max_size=300),  # mostly not MessagePack at all
    msgpack_values.map(msgspec.msgpack.encode),  # MessagePack of the wrong shape
    st.sampled_from(FORGED),  # the protocol, from an outsider
)
identities = st.one_of(
    st.none(),  # ZeroMQ picks one
    st.binary(min_size=1, max_size=40),  # an unknown binary identity
    st.sampled_from(NAMES),  # impersonating a component by name
    st.text("0123456789abcdef", min_size=32, max_size=32).map(str.encode),  # a guessed token
)


@dataclasses.dataclass(frozen=True)
class RawBytes:
    """A plain TCP connection that sends bytes (not ZeroMQ, or half a ZeroMQ greeting)."""

    target: str
    data: bytes
    hold: bool  # keep the connection open until the end instead of closing at once


@dataclasses.dataclass(frozen=True)
class Peer:
    """A ZeroMQ DEALER that connects ``times`` times and sends ``message`` (one or more frames)."""

    target: str
    identity: bytes | None
    message: tuple[bytes, ...]
    times: int
    hold: bool


ZMTP_GREETING = b"\xff\x00\x00\x00\x00\x00\x00\x00\x01\x7f\x03\x00NULL"
actions = st.one_of(
    st.builds(
        RawBytes,
        st.sampled_from(TARGETS),
        st.one_of(
            st.binary(min_size=1, max_size=600),
            st.binary(max_size=40).map(lambda tail: ZMTP_GREETING + tail),
        ),
        st.booleans(),
    ),
    st.builds(
        Peer,
        st.sampled_from(TARGETS),
        identities,
        st.lists(frames, min_size=1, max_size=4).map(tuple),
        st.integers(1, 3),
        st.booleans(),
    ),
)


class Attacker:
    """Carries out actions against a simulation's endpoints; holds connections until closed."""

    def __init__(self, targets: dict[str, str]) -> None:
        self.targets = targets
        self.zctx = zmq.Context()
        self._held: list[Any] = []

    def _address(self, target: str) -> tuple[str, int]:
        host, port = self.targets[target].removeprefix("tcp://").rsplit(":", 1)
        return host, int(port)

    def run(self, action: RawBytes | Peer) -> None:
        if isinstance(action, RawBytes):
            conn = socket.create_connection(self._address(action.target), timeout=5)
            with contextlib.suppress(OSError):  # the peer may reset a garbage connection
                conn.sendall(action.data)
            if action.hold:
                self._held.append(conn)
            else:
                conn.close()
            return
        for _ in range(action.times):
            sock = self.zctx.socket(zmq.DEALER)
            sock.setsockopt(zmq.LINGER, 200)  # flush what was sent, even when closed at once
            if action.identity is not None:
                sock.setsockopt(zmq.ROUTING_ID, action.identity)
            sock.connect(self.targets[action.target])
            sock.send_multipart(list(action.message))
            if action.hold:
                self._held.append(sock)
            else:
                sock.close()

    def answers(self) -> int:
        """How many answers held ZeroMQ peers received (an outsider must get none)."""
        count = 0
        for sock in self._held:
            if isinstance(sock, zmq.Socket):
                while sock.poll(0):
                    sock.recv_multipart()
                    count += 1
        return count

    def close(self) -> None:
        for held in self._held:
            held.close()
        self.zctx.term()


def attack_during(
    simulation: Any, plan: list[RawBytes | Peer], missions: Sequence[rover.Mission] = MISSIONS
) -> tuple[list[Any], int]:
    """Fly ``missions`` while a thread carries out ``plan``; return them and the answers."""
    attacker = Attacker(endpoints(simulation))
    errors: list[BaseException] = []
    go = threading.Event()

    def attack() -> None:
        go.wait(10)
        try:
            for action in plan:
                attacker.run(action)
        except BaseException as exc:  # reported by the main thread
            errors.append(exc)

    thread = threading.Thread(target=attack)
    thread.start()
    try:
        # Half of the plan lands before the missions, the rest while they run.
        for action in plan[: len(plan) // 2]:
            attacker.run(action)
        go.set()
        trajectories = fly(simulation, missions)
        thread.join(30)
        answers = attacker.answers()
    finally:
        go.set()
        thread.join(30)
        attacker.close()
    assert not errors, errors
    return trajectories, answers


# -- the fuzz test ----------------------------------------------------------------------------


@settings(
    max_examples=10,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(plan=st.lists(actions, min_size=1, max_size=10))
def test_fuzzed_traffic_leaves_the_run_unchanged(plan: list[RawBytes | Peer]) -> None:
    expected = list(reference())
    with live_rover() as simulation:
        trajectories, answers = attack_during(simulation, plan)
        members = [m.name for m in simulation.simulation.environment.scheduler.members]
    assert trajectories == expected
    assert answers == 0, "an outsider got an answer"
    assert members == ["world", "controller"], "an outsider joined the lockstep"


# -- each hostile case, with the warning it leaves --------------------------------------------

CASES: dict[str, RawBytes | Peer] = {
    # ZeroMQ reads bytes that start like this as a peer of its first protocol version (an
    # empty identity, then length-prefixed frames): they arrive as frames from an unknown
    # identity, and are dropped.
    "random TCP bytes": RawBytes(
        "", b"\x01\x00" + b"\x06\x00hello" * 3 + bytes(range(256)), hold=False
    ),
    # An HTTP request or half a greeting fails ZeroMQ's handshake: refused, and logged.
    "an HTTP request": RawBytes("", b"GET / HTTP/1.1\r\nHost: x\r\n\r\n", hold=False),
    "half a ZeroMQ greeting": RawBytes("", ZMTP_GREETING[:5], hold=False),
    # A first byte of 0 is a protocol error ZeroMQ closes silently: nothing to log, but the
    # run must not notice either.
    "bytes ZeroMQ drops silently": RawBytes("", bytes(range(256)) * 2, hold=True),
    "not MessagePack": Peer("", None, (b"\xc1 not msgpack",), 1, hold=True),
    "MessagePack of the wrong shape": Peer(
        "", None, (msgspec.msgpack.encode({"tag": "hello", "n": [1, 2]}),), 1, hold=True
    ),
    "two frames": Peer("", None, (FORGED[0], FORGED[5]), 1, hold=True),
    "unknown binary identity": Peer("", b"\x00\x01\xfe\xff", (FORGED[6],), 1, hold=True),
    "impersonating the world": Peer("", b"world", FORGED[:4], 1, hold=True),
    "impersonating the controller": Peer("", b"controller", (FORGED[5],), 1, hold=True),
    "a guessed token": Peer("", b"0" * 32, (FORGED[3], FORGED[5]), 1, hold=True),
}


def _aim(action: RawBytes | Peer, target: str) -> RawBytes | Peer:
    return dataclasses.replace(action, target=target)


@pytest.mark.parametrize("target", TARGETS)
def test_each_hostile_case_is_dropped_with_a_warning_naming_the_peer(
    target: str, caplog: pytest.LogCaptureFixture
) -> None:
    # One simulation takes every case in turn, a mission after each: the missions must
    # continue exactly as in an undisturbed run of as many missions.
    caplog.set_level(logging.WARNING, logger="multicosim")
    trajectories = []
    with live_rover() as simulation:
        where = endpoints(simulation)[target]
        log = simulation.logs()["controller"]
        for (case, action), mission in zip(CASES.items(), plan_of(len(CASES)), strict=True):
            caplog.clear()
            seen = len(log.read_text())
            plan = [_aim(action, target)] * 2
            flown, answers = attack_during(simulation, plan, missions=[mission])
            trajectories += flown
            assert answers == 0, case
            needles = ("dropped a frame", "refused a connection")
            if target == "firmware":  # a process: its warnings are in its log
                text = _wait_for(functools.partial(_tail, log, seen), needles)
            else:
                # Between missions the host reads the coordinator's socket only while it
                # waits for something: a ping makes it read what is queued.
                text = _wait_for(lambda: caplog.text, needles, simulation.controller.ping)
            if case == "random TCP bytes":
                assert "dropped a frame from peer at an unknown address (identity" in text, case
            elif case in ("an HTTP request", "half a ZeroMQ greeting"):
                assert f"refused a connection to {where}" in text, case
            elif isinstance(action, Peer):
                assert "dropped a frame from peer 127.0.0.1 (identity" in text, case
                if action.identity is not None:
                    assert repr(action.identity) in text, case
            else:  # ZeroMQ closed it without a word: there is nothing to report
                assert "dropped a frame" not in text, case
        members = [m.name for m in simulation.simulation.environment.scheduler.members]
    assert trajectories == list(reference(len(CASES)))
    assert members == ["world", "controller"]


def _tail(log: Path, start: int) -> str:
    return log.read_text()[start:]


def _wait_for(
    read: Callable[[], str],
    needles: tuple[str, ...],
    between: Callable[[], object] = lambda: None,
    timeout: float = 5.0,
) -> str:
    """``read()`` once it holds one of ``needles`` (or after ``timeout``).

    Frames are dropped as they are read and refused connections logged as ZeroMQ reports
    them; both happen a little after the attacker sent them.
    """
    deadline = time.monotonic() + timeout
    while True:
        text = read()
        if any(n in text for n in needles) or time.monotonic() > deadline:
            return text
        between()
        time.sleep(0.02)


def test_warnings_of_a_flood_are_bounded(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, logger="multicosim")
    with live_rover() as simulation:
        attacker = Attacker(endpoints(simulation))
        try:
            sock = attacker.zctx.socket(zmq.DEALER)
            sock.setsockopt(zmq.ROUTING_ID, b"flooder")
            sock.connect(endpoints(simulation)["coordinator"])
            for _ in range(500):
                sock.send(b"junk")
            sock.close(linger=2000)
            trajectories = fly(simulation)
            drops = simulation.simulation.environment.coordinator.drops
        finally:
            attacker.close()
    assert trajectories == list(reference())
    assert drops.count == 500  # every frame was dropped (and counted)...
    warnings = [r.getMessage() for r in caplog.records if "b'flooder'" in r.getMessage()]
    assert len(warnings) <= 10, warnings  # ... but only a few were logged
    assert any("further frames from" in w for w in warnings)
