"""Offboard setpoints that stop: the built-in autopilot does what PX4 v1.15 does.

A pymavlink client streams offboard position setpoints to the autopilot (medium fidelity,
in a thread, over loopback UDP), then stalls its stream on purpose for a few simulated
seconds, measured on the autopilot's own clock (its time_boot_ms). PX4 v1.15 declares
offboard lost after COM_OF_LOSS_T without a setpoint and falls back to COM_OBL_RC_ACT's
mode (0: Position; without sticks the vehicle holds where it is); when the setpoints come
back, the user's offboard mode resumes (the fallback clears with its condition). Paced at
8x real time, COM_OF_LOSS_T is PX4's SITL value for that speed (``paced_params``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest

from multicosim.px4.modes import Mode, decode_custom_mode
from multicosim.px4.standalone import paced_params

mavutil = pytest.importorskip("pymavlink.mavutil")

SPEED = 8.0
LOSS_T = paced_params(SPEED)["COM_OF_LOSS_T"]  # simulated seconds without a setpoint: lost
POSITION_ONLY = 0b0000_1111_1111_1000  # SET_POSITION_TARGET type_mask: position (and yaw)


class Client:
    """A pymavlink offboard client that knows the autopilot's simulated time."""

    def __init__(self, port: int) -> None:
        self.conn: Any = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=255, source_component=190, dialect="common"
        )
        self.sim_ms = 0
        self.mode: tuple[int, int] = (0, 0)
        self.armed = False
        self.pos = (0.0, 0.0, 0.0)

    def pump(self, wall: float = 0.05) -> None:
        """Read what the autopilot sent (its clock, mode, local position)."""
        m = self.conn.recv_match(blocking=True, timeout=wall)
        while m is not None:
            t = getattr(m, "time_boot_ms", None)
            if isinstance(t, int) and t > self.sim_ms:
                self.sim_ms = t
            kind = m.get_type()
            if kind == "HEARTBEAT" and m.get_srcComponent() == 1:
                self.mode = decode_custom_mode(m.custom_mode)
                self.armed = bool(m.base_mode & 128)
            elif kind == "LOCAL_POSITION_NED":
                self.pos = (m.x, m.y, m.z)
            m = self.conn.recv_match(blocking=False)

    def setpoint(self, n: float, e: float, d: float) -> None:
        self.conn.mav.set_position_target_local_ned_send(
            self.sim_ms, 1, 1, 1, POSITION_ONLY, n, e, d, 0, 0, 0, 0, 0, 0, 0.0, 0
        )

    def command(self, cmd: int, *params: float) -> None:
        self.conn.mav.command_long_send(1, 1, cmd, 0, *params, *[0.0] * (7 - len(params)))

    def run(
        self, seconds: float, stream: tuple[float, float, float] | None, wall: float = 60.0
    ) -> list[tuple[float, tuple[int, int], tuple[float, float, float]]]:
        """``seconds`` simulated, streaming ``stream`` at 20 Hz (or nothing); what was seen."""
        import time

        start, seen = self.sim_ms, []
        deadline = time.monotonic() + wall
        while self.sim_ms - start < seconds * 1000:
            if time.monotonic() > deadline:
                pytest.fail(f"the simulation stalled ({self.sim_ms} ms)")
            if stream is not None:
                self.setpoint(*stream)
            self.pump(0.05 / SPEED)
            seen.append((self.sim_ms * 1e-3, self.mode, self.pos))
        return seen

    def close(self) -> None:
        self.conn.close()


@pytest.fixture
def client(udp_port: int, sitl_thread: Any) -> Iterator[Client]:
    """The autopilot (medium fidelity, 8x real time) and an offboard client talking to it."""
    c = Client(udp_port)
    try:
        with sitl_thread(udp_port, "medium", SPEED):
            yield c
    finally:
        c.close()


def _offboard_at(c: Client, target: tuple[float, float, float], seconds: float) -> None:
    c.run(1.0, target)
    c.command(176, 1, 6, 0)  # DO_SET_MODE: custom, OFFBOARD
    seen = c.run(seconds, target)
    assert seen[-1][1] == Mode.OFFBOARD.value, seen[-1]


def test_a_stalled_setpoint_stream_holds_position_and_offboard_resumes(client: Client) -> None:
    c = client
    c.run(15.0, None)  # the estimator settles; position valid
    c.command(400, 1)  # arm
    c.run(0.5, (0.0, 0.0, -3.0))
    _offboard_at(c, (0.0, 0.0, -3.0), 12.0)
    assert c.armed
    _offboard_at(c, (5.0, 0.0, -3.0), 3.0)  # on the way to 5 m north
    stalled_at = c.pos
    # The stream stalls for longer than COM_OF_LOSS_T.
    stall = c.run(LOSS_T + 4.0, None)
    lost = [t for t, mode, _ in stall if mode == Mode.POSCTL.value]
    assert lost, f"offboard was never declared lost: {[m for _, m, _ in stall][-5:]}"
    assert LOSS_T - 0.5 < lost[0] - stall[0][0] < LOSS_T + 1.0, "not lost after COM_OF_LOSS_T"
    # Without sticks, Position mode holds: the vehicle brakes and stays near the stall point.
    for _, _, pos in stall:
        assert math.dist(pos, stalled_at) < 4.0, (pos, stalled_at)
    # The setpoints come back: offboard resumes and the vehicle flies to them.
    back = c.run(10.0, (5.0, 0.0, -3.0))
    assert back[-1][1] == Mode.OFFBOARD.value, back[-1]
    assert math.dist(back[-1][2], (5.0, 0.0, -3.0)) < 1.0, back[-1]


def test_late_setpoints_within_the_loss_time_keep_offboard(client: Client) -> None:
    # Setpoints 0.8 COM_OF_LOSS_T apart (a loaded client): never lost, never flown off.
    c = client
    c.run(15.0, None)
    c.command(400, 1)
    c.run(0.5, (0.0, 0.0, -3.0))
    _offboard_at(c, (0.0, 0.0, -3.0), 10.0)
    seen = []
    for _ in range(8):
        c.setpoint(0.0, 5.0, -3.0)
        seen += c.run(0.8 * LOSS_T, None)
    assert all(mode == Mode.OFFBOARD.value for _, mode, _ in seen)
    assert math.dist(seen[-1][2], (0.0, 5.0, -3.0)) < 1.0, seen[-1]
