"""Our autopilot speaks PX4's MAVLink: checked with pymavlink over real UDP sockets.

The autopilot runs in a thread (``run_sitl``) at a multiple of real time and sends to the
port our pymavlink "ground station" listens on; every receive has a timeout.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import pytest

from multicosim.px4.modes import MainMode, Mode, SubMode, decode_custom_mode

mavutil = pytest.importorskip("pymavlink.mavutil")

SPEED = 10.0


class Gcs:
    """A pymavlink ground station on a loopback UDP port."""

    def __init__(self, port: int) -> None:
        self.conn: Any = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=255, source_component=190, dialect="common"
        )
        self.mav = self.conn.mav

    def recv(self, kind: str | list[str], timeout: float = 5.0, cond: Any = None) -> Any:
        """The next ``kind`` message (matching ``cond``); fails after ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            m = self.conn.recv_match(type=kind, blocking=True, timeout=left)
            if m is not None and (cond is None or cond(m)):
                return m
        pytest.fail(f"no {kind} within {timeout} s")

    def command(self, cmd: int, *params: float, timeout: float = 5.0) -> int:
        p = [*params, *([math.nan if False else 0.0] * (7 - len(params)))]
        self.mav.command_long_send(1, 1, cmd, 0, *p)
        return int(self.recv("COMMAND_ACK", timeout, lambda m: m.command == cmd).result)

    def close(self) -> None:
        self.conn.close()


@pytest.fixture
def gcs(udp_port: int, sitl_thread: Any) -> Iterator[Gcs]:
    """An autopilot (low fidelity, 10x real time) and a ground station talking to it."""
    station = Gcs(udp_port)
    try:
        with sitl_thread(udp_port, "low", SPEED):
            station.recv("HEARTBEAT", 10)
            yield station
    finally:
        station.close()


def test_heartbeat_presents_a_px4_quadrotor(gcs: Gcs) -> None:
    hb = gcs.recv("HEARTBEAT")
    assert hb.autopilot == 12  # MAV_AUTOPILOT_PX4
    assert hb.type == 2  # MAV_TYPE_QUADROTOR
    assert hb.base_mode & 1  # MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert decode_custom_mode(hb.custom_mode) == (MainMode.AUTO, SubMode.LOITER)
    assert hb.get_header().srcSystem == 1
    assert gcs.conn.WIRE_PROTOCOL_VERSION == "2.0" or hb.get_msgbuf()[0] == 0xFD


def test_custom_mode_encoding_matches_px4() -> None:
    # px4_custom_mode.h: main mode in bits 16..23, sub mode in bits 24..31.
    assert Mode.MISSION.custom_mode == 0x04040000
    assert Mode.POSCTL.custom_mode == 0x00030000
    assert Mode.RTL.custom_mode == 0x05040000
    assert Mode.LAND.label == "AUTO.LAND"


def test_telemetry_streams(gcs: Gcs) -> None:
    for kind in (
        "SYS_STATUS",
        "GPS_RAW_INT",
        "GLOBAL_POSITION_INT",
        "LOCAL_POSITION_NED",
        "ATTITUDE",
        "EXTENDED_SYS_STATE",
    ):
        gcs.recv(kind, 5)
    home = gcs.recv("HOME_POSITION", 10)
    assert home.latitude == pytest.approx(473977420, abs=50)
    gpi = gcs.recv("GLOBAL_POSITION_INT")
    assert abs(gpi.relative_alt) < 500  # mm: on the ground at home
    gps = gcs.recv("GPS_RAW_INT", cond=lambda m: m.fix_type >= 3)
    assert gps.satellites_visible >= 6
    assert gcs.recv("EXTENDED_SYS_STATE").landed_state == 1  # ON_GROUND


def test_autopilot_version_on_request(gcs: Gcs) -> None:
    assert gcs.command(512, 148) == 0  # MAV_CMD_REQUEST_MESSAGE(AUTOPILOT_VERSION)
    version = gcs.recv("AUTOPILOT_VERSION")
    assert version.capabilities & 4  # MISSION_INT
    assert version.flight_sw_version >> 24 == 1


def test_parameter_protocol(gcs: Gcs) -> None:
    gcs.mav.param_request_list_send(1, 1)
    names = set()
    first = gcs.recv("PARAM_VALUE")
    names.add(first.param_id)
    while len(names) < first.param_count:
        names.add(gcs.recv("PARAM_VALUE").param_id)
    assert {"MPC_XY_CRUISE", "NAV_ACC_RAD", "RTL_RETURN_ALT"} <= names
    gcs.mav.param_set_send(1, 1, b"MPC_XY_CRUISE", 7.5, 9)
    echo = gcs.recv("PARAM_VALUE", cond=lambda m: m.param_id == "MPC_XY_CRUISE")
    assert echo.param_value == pytest.approx(7.5)
    gcs.mav.param_set_send(1, 1, b"MPC_XY_CRUISE", 500.0, 9)  # out of range: PX4 takes it
    echo = gcs.recv("PARAM_VALUE", cond=lambda m: m.param_id == "MPC_XY_CRUISE")
    assert echo.param_value == pytest.approx(500.0)
    gcs.mav.param_request_read_send(1, 1, b"NAV_ACC_RAD", -1)
    assert gcs.recv("PARAM_VALUE", cond=lambda m: m.param_id == "NAV_ACC_RAD").param_value == 2.0


def _upload(
    gcs: Gcs, items: list[tuple[int, int, int, float]], texts: list[str] | None = None
) -> int:
    gcs.mav.mission_count_send(1, 1, len(items), 0)
    for _ in items:
        req = gcs.recv("MISSION_REQUEST_INT")
        cmd, lat, lon, alt = items[req.seq]
        gcs.mav.mission_item_int_send(
            1, 1, req.seq, 6, cmd, 0, 1, 0, 2.0, 0, math.nan, lat, lon, alt, 0
        )
    while (m := gcs.recv(["MISSION_ACK", "STATUSTEXT"])).get_type() == "STATUSTEXT":
        if texts is not None:
            texts.append(m.text)
    return int(m.type)


def test_mission_protocol_upload_download_clear(gcs: Gcs) -> None:
    items = [(22, 0, 0, 10.0), (16, 473980000, 85460000, 15.0), (21, 473980000, 85460000, 0.0)]
    assert _upload(gcs, items) == 0  # MAV_MISSION_ACCEPTED
    gcs.mav.mission_request_list_send(1, 1, 0)
    assert gcs.recv("MISSION_COUNT").count == 3
    gcs.mav.mission_request_int_send(1, 1, 1, 0)
    item = gcs.recv("MISSION_ITEM_INT")
    assert (item.seq, item.command, item.x, item.y, item.z) == (1, 16, 473980000, 85460000, 15.0)
    gcs.mav.mission_clear_all_send(1, 1, 0)
    assert gcs.recv("MISSION_ACK").type == 0
    gcs.mav.mission_request_list_send(1, 1, 0)
    assert gcs.recv("MISSION_COUNT").count == 0


def test_mission_outside_geofence_is_rejected(gcs: Gcs) -> None:
    gcs.recv("HOME_POSITION", 10)
    far = (16, 475000000, 85460000, 20.0)  # about 11 km north
    texts: list[str] = []
    assert _upload(gcs, [far], texts) == 1  # MAV_MISSION_ERROR
    assert any("geofence" in t for t in texts), texts


def test_commands_arm_takeoff_land(gcs: Gcs) -> None:
    gcs.recv("SYS_STATUS", 10, cond=lambda m: m.onboard_control_sensors_health & 0x10000000)
    assert gcs.command(300) == 2  # mission start without a mission: denied, as PX4 does
    assert gcs.command(400, 1) == 0  # arm
    assert gcs.recv("HEARTBEAT", cond=lambda m: m.base_mode & 128).system_status == 4
    assert gcs.command(22, 0, 0, 0, math.nan, math.nan, math.nan, 488.0 + 5.0) == 0  # takeoff
    gcs.recv("GLOBAL_POSITION_INT", 20, cond=lambda m: m.relative_alt > 4000)
    gcs.recv("HEARTBEAT", 10, cond=lambda m: decode_custom_mode(m.custom_mode) == (4, 3))
    assert gcs.command(400, 0) == 2  # disarm in the air: denied
    assert gcs.command(21) == 0  # land
    gcs.recv("EXTENDED_SYS_STATE", 30, cond=lambda m: m.landed_state == 1)
    gcs.recv("HEARTBEAT", 10, cond=lambda m: not m.base_mode & 128)  # auto-disarmed


def test_unsupported_and_malformed_commands(gcs: Gcs) -> None:
    assert gcs.command(31000) == 3  # MAV_RESULT_UNSUPPORTED
    # NaN where an integer belongs must not upset the autopilot.
    gcs.mav.command_long_send(1, 1, 400, 0, 1, math.nan, 0, 0, 0, 0, 0)
    gcs.recv("COMMAND_ACK", cond=lambda m: m.command == 400)
    gcs.recv("HEARTBEAT")


def test_timesync(gcs: Gcs) -> None:
    gcs.mav.timesync_send(0, 123456789)
    reply = gcs.recv("TIMESYNC", cond=lambda m: m.ts1 == 123456789)
    assert reply.tc1 > 0
