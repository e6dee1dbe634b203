"""The built-in autopilot answers over MAVLink as real PX4 v1.15.4 does.

Real PX4's answers were recorded from the PX4 SITL binary flying our world by
``scripts/record_px4.py`` (``multicosim/px4/data/px4-1.15.4.json``). Here the built-in
autopilot, run standalone as ``multicosim px4 sitl`` on loopback UDP, is asked the same
questions in the same order by :func:`multicosim.px4.conformance.record`, and every answer
is compared: heartbeat, streams and rates, parameters (names, types, values), parameter,
command, mode and mission protocol answers.
"""

from __future__ import annotations

import socket
from typing import Any

import pytest

from multicosim.px4 import conformance
from multicosim.px4.standalone import paced_params

pytest.importorskip("pymavlink")

SPEED = 20.0


@pytest.fixture
def builtin_answers(sitl: Any, udp_port: int) -> dict[str, Any]:
    """The built-in autopilot's answers, standalone at medium fidelity."""
    args = ("--fidelity", "medium", "--speed", str(SPEED), "--gcs-port", "0")
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
    from multicosim.mavlink.dialect import new_link

    link = conformance._Link(udp_port, timeout=5.0)
    autopilot = new_link(1, 1)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            for ms in range(0, 10_001, 100):
                msg = autopilot.attitude_encode(ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
                sender.sendto(msg.pack(autopilot), ("127.0.0.1", udp_port))
        link.catch_up()
        assert link.sim_ms == 10_000
        assert link.counts["ATTITUDE"] == 101
    finally:
        link.close()
