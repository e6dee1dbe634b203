"""The built-in autopilot answers over MAVLink as real PX4 v1.15.4 does.

Real PX4's answers were recorded from the PX4 SITL binary flying our world by
``scripts/record_px4.py`` (``multicosim/px4/data/px4-1.15.4.json``). Here the built-in
autopilot, run standalone as ``multicosim px4 sitl`` on loopback UDP, is asked the same
questions in the same order by :func:`multicosim.px4.conformance.record`, and every answer
is compared: heartbeat, streams and rates, parameters (names, types, values), parameter,
command, mode and mission protocol answers, and what flying does (a takeoff's altitude,
DO_REPOSITION in Hold, offboard setpoints that stop or lie far away), within tolerances.
"""

from __future__ import annotations

import socket
from typing import Any

import pytest

from multicosim.mavlink.dialect import new_link
from multicosim.px4 import conformance
from multicosim.px4.probe import AutopilotStalled, Probe
from multicosim.px4.standalone import paced_params

pytest.importorskip("pymavlink")

SPEED = 20.0


@pytest.fixture
def builtin_answers(sitl: Any, udp_port: int) -> dict[str, Any]:
    """The built-in autopilot's answers, standalone at medium fidelity."""
    args: tuple[str, ...] = ("--fidelity", "medium", "--speed", str(SPEED), "--gcs-port", "0")
    args += ("--api-port", str(udp_port))
    with sitl(*args):
        answers: dict[str, Any] = conformance.record(udp_port)
    return answers


def test_the_recorded_px4_is_v1_15_4() -> None:
    data = conformance.load()
    assert data["px4"] == "1.15.4"
    assert data["params"]["NAV_ACC_RAD"]["default"] == 10.0  # PX4's firmware default
    assert data["params"]["NAV_ACC_RAD"]["value"] == 2.0  # as its SITL start-up sets it


def test_builtin_autopilot_answers_as_px4_does(builtin_answers: dict[str, Any]) -> None:
    # PX4 paced at SPEED reports the loss timeouts its SITL start-up lengthens for that speed.
    px4 = conformance.load()
    for name, value in paced_params(SPEED).items():
        px4["params"][name] = {**px4["params"][name], "value": value}
    diffs = conformance.differences(px4, builtin_answers)
    assert diffs == [], "\n".join(diffs)


def test_differences_are_found() -> None:
    px4 = conformance.load()
    other = {**px4, "streams": {}, "commands": {**px4["commands"], "USER_1": 0}}
    diffs = conformance.differences(px4, other)
    assert any(d.startswith("stream ATTITUDE_QUATERNION") for d in diffs)
    assert any("USER_1" in d for d in diffs)


def test_the_probe_catches_up_with_a_backlog_before_it_asks(udp_port: int) -> None:
    # Ten simulated seconds of telemetry wait unread (the probe was descheduled): the probe
    # reads them before its next question, so that the answer's window starts from the
    # autopilot's latest time, not from the backlog's oldest.
    link = Probe(udp_port, timeout=5.0)
    autopilot = new_link(1, 1)
    try:
        backlog = [
            (autopilot, autopilot.attitude_encode(ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
            for ms in range(0, 10_001, 100)
        ]
        _send(udp_port, *backlog)
        link.catch_up()
        assert link.sim_ms == 10_000
        assert link.counts["ATTITUDE"] == 101
    finally:
        link.close()


def test_flown_answers_are_compared_within_their_tolerances() -> None:
    px4 = conformance.load()
    flight = px4["flight"]
    takeoff = flight["takeoff to 10 m"]
    near = {**takeoff, "altitude": takeoff["altitude"] + 0.2}
    far = {**takeoff, "altitude": takeoff["altitude"] + 0.5}
    assert (
        conformance.differences(px4, {**px4, "flight": {**flight, "takeoff to 10 m": near}}) == []
    )
    diffs = conformance.differences(px4, {**px4, "flight": {**flight, "takeoff to 10 m": far}})
    assert diffs == [
        f"flight / takeoff to 10 m / altitude: {far['altitude']!r}, PX4 {takeoff['altitude']!r}"
    ]
    accepted = {**flight, "reposition in hold": {**flight["reposition in hold"], "result": 0}}
    assert conformance.differences(px4, {**px4, "flight": accepted}) == [
        "flight / reposition in hold / result: 0, PX4 3"
    ]


def _send(port: int, *messages: tuple[Any, Any]) -> None:
    """Send each (encoder, message) to ``port`` on loopback, as an autopilot does."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        for link, msg in messages:
            sender.sendto(msg.pack(link), ("127.0.0.1", port))


def test_the_probe_talks_to_the_system_that_sent_the_heartbeat(udp_port: int) -> None:
    # Real PX4 SITL instance N is system N + 1: the probe takes the system id from the first
    # autopilot heartbeat and ignores other systems.
    link = Probe(udp_port, timeout=5.0)
    autopilot, stranger = new_link(3, 1), new_link(7, 1)
    try:
        _send(
            udp_port,
            (autopilot, autopilot.heartbeat_encode(2, 12, 0, 0, 3)),
            (stranger, stranger.attitude_encode(5_000, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
            (autopilot, autopilot.attitude_encode(1_000, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
        )
        link.catch_up()
        assert link.target == (3, 1)
        assert link.sim_ms == 1_000
        assert link.counts["ATTITUDE"] == 1
    finally:
        link.close()


def test_a_wait_ends_when_the_autopilots_clock_stops(udp_port: int) -> None:
    # A lockstep autopilot whose simulation stopped sends no later time: the wait raises
    # rather than waiting out every later question.
    link = Probe(udp_port, timeout=60.0, stall=0.5)
    autopilot = new_link(1, 1)
    try:
        _send(udp_port, (autopilot, autopilot.attitude_encode(1_000, 0, 0, 0, 0, 0, 0)))
        with pytest.raises(AutopilotStalled, match="stayed at 1000 ms"):
            link.wait(lambda m: False, 10.0)
    finally:
        link.close()


def test_a_wait_ends_when_the_autopilot_exits(udp_port: int) -> None:
    link = Probe(udp_port, timeout=60.0, alive=lambda: False)
    try:
        with pytest.raises(AutopilotStalled, match="exited"):
            link.wait(lambda m: False, 10.0)
    finally:
        link.close()
