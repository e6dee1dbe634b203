"""What a PX4 autopilot answers over MAVLink, recorded and compared.

``record(port)`` asks an autopilot on a MAVLink UDP link (sending to ``port`` on loopback)
the same questions in the same order and records its answers: its heartbeat, the messages
it streams and their rates, its parameters (names, types, values; with ``metadata`` PX4's
own parameter metadata, read over MAVLink FTP: defaults and ranges), its answer to each
command in each state, its flight modes, the mission protocol (mission items in the
mission frame, DO_JUMP and MISSION_SET_CURRENT onto it, geofence and rally lists, the legacy
MISSION_REQUEST), which mission items it takes in which frame (``conformance_items``),
and what flying does: a takeoff's altitude held, DO_REPOSITION in Hold,
offboard setpoints that stop and one far away (``conformance_flight``). The questions
are asked with a ``Probe``, on the autopilot's simulated clock.

``scripts/record_px4.py`` records real PX4 SITL flying our world into
``multicosim/px4/data/px4-<version>.json``; the built-in autopilot's parameter table and
stream rates come from that file, and ``tests/px4/test_conformance.py`` records the built-in
autopilot the same way and compares with ``differences``.
"""

from __future__ import annotations

import json
import lzma
import math
from collections.abc import Callable
from importlib import resources
from typing import Any

from ..mavlink.dialect import (
    CMD_DO_JUMP,
    CMD_FENCE_POLYGON_INCLUSION,
    CMD_RALLY_POINT,
    CMD_RTL,
    CMD_TAKEOFF,
    CMD_WAYPOINT,
    FRAME_GLOBAL_INT,
    FRAME_GLOBAL_REL_INT,
    FRAME_MISSION,
    MSG_AUTOPILOT_VERSION,
    MSG_FLIGHT_INFORMATION,
    MSG_GPS_GLOBAL_ORIGIN,
    MSG_HEARTBEAT,
    MSG_HIL_STATE_QUATERNION,
    MSG_HOME_POSITION,
    MSG_PROTOCOL_VERSION,
)
from .conformance_flight import differences as flight_differences
from .conformance_flight import flight
from .conformance_items import item_answers
from .modes import Mode
from .probe import Probe, int_bytes, param_name, param_value

__all__ = ["PX4_VERSION", "differences", "load", "record"]

PX4_VERSION = "1.15.4"
WINDOW = 20.0  # simulated seconds of streams counted for the rates

MSG_UNKNOWN = 9999  # a message id no dialect has


def _streams(link: Probe) -> dict[str, float]:
    link.counts.clear()
    link.wait(lambda m: False, 1.0)  # settle on a clock
    link.counts.clear()
    start = link.sim_ms
    link.sleep(WINDOW)
    span = (link.sim_ms - start) / 1000.0
    rates = {}
    for name, n in sorted(link.counts.items()):
        if name in ("STATUSTEXT", "COMMAND_ACK", "PARAM_VALUE") or name.startswith("UNKNOWN"):
            continue
        rates[name] = round(n / span, 1) if span > 0 else 0.0
    return rates


def _params(link: Probe) -> dict[str, Any]:
    values: dict[int, tuple[str, int, Any]] = {}
    count = None
    for _ in range(4):
        if count is None:
            # (Again, while nothing has come: a datagram may be lost on a busy host, and
            # ground stations ask again too; each time from a caught-up clock.)
            link.catch_up()
            link.mav.param_request_list_send(*link.target)
        # Until all have come, or none for 2 s (simulated).
        while count is None or len(values) < count:
            m = link.wait(lambda m: m.get_type() == "PARAM_VALUE", 2.0)
            if m is None:
                break
            count = m.param_count
            values[m.param_index] = (param_name(m.param_id), int(m.param_type), param_value(m))
        if count is not None and len(values) >= count:
            break
        for i in range(count or 0):
            if i not in values:
                link.mav.param_request_read_send(*link.target, b"", i)
    params = {name: {"type": t, "value": v} for name, t, v in values.values()}
    return {"count": count, "params": dict(sorted(params.items()))}


def _param_answers(link: Probe) -> dict[str, Any]:
    """How reads and sets of known and unknown names are answered."""

    def answer(send: Callable[[], None]) -> dict[str, Any]:
        return link.param(send)

    as_int = int_bytes(7)
    mav, to = link.mav, link.target
    return {
        "read_unknown": answer(lambda: mav.param_request_read_send(*to, b"NO_SUCH_PARAM", -1)),
        "set_unknown": answer(lambda: mav.param_set_send(*to, b"NO_SUCH_PARAM", 1.0, 9)),
        "read_by_name": answer(lambda: mav.param_request_read_send(*to, b"NAV_ACC_RAD", -1)),
        "set_float": answer(lambda: mav.param_set_send(*to, b"MPC_XY_CRUISE", 6.0, 9)),
        "set_out_of_range": answer(lambda: mav.param_set_send(*to, b"MPC_XY_CRUISE", 500.0, 9)),
        "set_int": answer(lambda: mav.param_set_send(*to, b"COM_RCL_EXCEPT", as_int, 6)),
        "restore_int": answer(lambda: mav.param_set_send(*to, b"COM_RCL_EXCEPT", 0.0, 6)),
        "restore_float": answer(lambda: mav.param_set_send(*to, b"MPC_XY_CRUISE", 5.0, 9)),
    }


def _commands(link: Probe) -> dict[str, Any]:
    """Answers to commands on the ground, disarmed, in position hold."""
    nan = math.nan
    out: dict[str, Any] = {}
    for name, msgid in (
        ("AUTOPILOT_VERSION", MSG_AUTOPILOT_VERSION),
        ("PROTOCOL_VERSION", MSG_PROTOCOL_VERSION),
        ("HOME_POSITION", MSG_HOME_POSITION),
        ("GPS_GLOBAL_ORIGIN", MSG_GPS_GLOBAL_ORIGIN),
        ("FLIGHT_INFORMATION", MSG_FLIGHT_INFORMATION),
        ("UNKNOWN", MSG_UNKNOWN),
    ):
        out[f"REQUEST_MESSAGE {name}"] = link.command("REQUEST_MESSAGE", msgid)
    out["GET_MESSAGE_INTERVAL HEARTBEAT"] = link.command("GET_MESSAGE_INTERVAL", MSG_HEARTBEAT)
    out["SET_MESSAGE_INTERVAL HIL_STATE_QUATERNION"] = link.command(
        "SET_MESSAGE_INTERVAL", MSG_HIL_STATE_QUATERNION, 100_000
    )
    out["GET_HOME_POSITION"] = link.command("GET_HOME_POSITION")
    out["REQUEST_AUTOPILOT_CAPABILITIES"] = link.command("REQUEST_AUTOPILOT_CAPABILITIES", 1)
    out["DO_CHANGE_SPEED"] = link.command("DO_CHANGE_SPEED", 1, 4.0, -1)
    out["DO_SET_HOME current"] = link.command("DO_SET_HOME", 1)
    out["DO_SET_MISSION_CURRENT no mission"] = link.command("DO_SET_MISSION_CURRENT", 3)
    out["DO_PAUSE_CONTINUE disarmed"] = link.command("DO_PAUSE_CONTINUE", 0)
    out["DO_MOTOR_TEST"] = link.command("DO_MOTOR_TEST", 1, 0, 0, 1, 1)
    # (A motor failure would stop PX4 SITL's actuator outputs, and with them the lockstep.)
    out["INJECT_FAILURE baro off"] = link.command("INJECT_FAILURE", 3, 1, 0)
    out["INJECT_FAILURE baro ok"] = link.command("INJECT_FAILURE", 3, 0, 0)
    out["NAV_TAKEOFF disarmed"] = link.command("NAV_TAKEOFF", nan, 0, 0, nan, nan, nan, nan)
    out["MISSION_START no mission"] = link.command("MISSION_START", 0, 0)
    out["USER_1"] = link.command("USER_1")
    out["COMPONENT_ARM_DISARM disarm while disarmed"] = link.command("COMPONENT_ARM_DISARM", 0)
    return out


def _modes(link: Probe) -> dict[str, Any]:
    """DO_SET_MODE to each PX4 mode while disarmed: the result and the mode then reported."""
    out: dict[str, Any] = {}
    # Every mode PX4 v1.15 has, in the order of its numbers.
    for mode in sorted(Mode, key=lambda m: m.value):
        label, (main, sub) = mode.label, mode.value
        if mode == Mode.OFFBOARD:
            # Setpoints first, as ground stations send them. Without them real PX4 still takes
            # OFFBOARD while disarmed, and then none of its controllers runs: it sends no motor
            # outputs, and its lockstep simulation, which waits for them, stops.
            link.stream = link.setpoints(link.position())
            link.sleep(1.0)
        result = link.command("DO_SET_MODE", 1, main, sub)
        link.sleep(0.5)
        out[label] = {"result": result, "reported": link.mode()}
        link.command("DO_SET_MODE", 1, 4, 3)  # back to hold
        link.stream = None
        link.sleep(0.5)
    return out


def _mission_items(home: tuple[int, int]) -> list[tuple[Any, ...]]:
    lat, lon = home
    rel = FRAME_GLOBAL_REL_INT
    # seq, frame, command, params 1-4, x, y, z: takeoff, two waypoints, DO_JUMP back, RTL.
    return [
        (0, rel, CMD_TAKEOFF, 0.0, 0.0, 0.0, math.nan, lat, lon, 10.0),
        (1, rel, CMD_WAYPOINT, 0.0, 0.0, 0.0, math.nan, lat + 2000, lon, 10.0),
        (2, rel, CMD_WAYPOINT, 0.0, 0.0, 0.0, math.nan, lat + 2000, lon + 2000, 10.0),
        (3, FRAME_MISSION, CMD_DO_JUMP, 1.0, 1.0, 0.0, 0.0, 0, 0, 0.0),
        (4, FRAME_MISSION, CMD_RTL, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0),
    ]


def _missions(link: Probe) -> dict[str, Any]:
    out: dict[str, Any] = {}
    home = link.wait(lambda m: m.get_type() == "HOME_POSITION", 5.0)
    if home is None:
        link.command("REQUEST_MESSAGE", MSG_HOME_POSITION)
        home = link.wait(lambda m: m.get_type() == "HOME_POSITION", 5.0)
    origin = (home.latitude, home.longitude) if home is not None else (473977420, 85455940)
    items = _mission_items(origin)
    out["mission"] = link.upload(items, 0)
    # MISSION_SET_CURRENT onto the DO_JUMP item: the current item then reported (PX4 v1.15
    # takes the index as it is, without resolving the jump). Asked once the new mission is
    # taken (PX4 puts an idle vehicle's new mission back to its first item), and answered by
    # the last MISSION_CURRENT of a few (PX4 streams it at 1 Hz).
    link.sleep(2.0)
    link.catch_up()
    link.mav.mission_set_current_send(*link.target, 3)
    current = link.collect("MISSION_CURRENT", lambda m: int(m.seq), 3.0)
    out["set current onto DO_JUMP"] = current[-1] if current else None
    link.mav.mission_set_current_send(*link.target, 0)
    out["mission without jump"] = link.upload([items[0], items[1]], 0)
    corners = ((9000, 9000), (9000, -9000), (-9000, -9000), (-9000, 9000))
    fence = [
        (i, FRAME_GLOBAL_INT, CMD_FENCE_POLYGON_INCLUSION, 4.0, 0.0, 0.0, 0.0, lat, lon, 0.0)
        for i, (lat, lon) in enumerate((origin[0] + dx, origin[1] + dy) for dx, dy in corners)
    ]
    out["fence"] = link.upload(fence, 1)
    rally_at = (origin[0] + 3000, origin[1])
    rally = [(0, FRAME_GLOBAL_REL_INT, CMD_RALLY_POINT, 0.0, 0.0, 0.0, 0.0, *rally_at, 10.0)]
    out["rally"] = link.upload(rally, 2)
    # Download with the legacy request: which message answers it.
    link.catch_up()
    link.mav.mission_request_list_send(*link.target, 0)
    count = link.wait(lambda m: m.get_type() == "MISSION_COUNT", 2.0)
    out["download count"] = None if count is None else int(count.count)
    link.catch_up()
    link.mav.mission_request_send(*link.target, 0, 0)
    reply = link.wait(
        lambda m: m.get_type() in ("MISSION_ITEM", "MISSION_ITEM_INT", "MISSION_ACK"), 2.0
    )
    out["legacy MISSION_REQUEST answer"] = None if reply is None else reply.get_type()
    link.mav.mission_ack_send(*link.target, 0, 0)
    for mtype, label in ((1, "fence"), (2, "rally")):
        link.catch_up()
        link.mav.mission_request_list_send(*link.target, mtype)
        c = link.wait(lambda m, t=mtype: m.get_type() == "MISSION_COUNT" and m.mission_type == t, 2)
        out[f"download {label} count"] = None if c is None else int(c.count)
        if c is not None and c.count:
            link.mav.mission_ack_send(*link.target, 0, mtype)
    for mtype in (1, 2):
        link.catch_up()
        link.mav.mission_clear_all_send(*link.target, mtype)
        link.wait(lambda m: m.get_type() == "MISSION_ACK", 1.0)
    return out


def _heartbeat(hb: Any) -> dict[str, Any]:
    return {
        "type": hb.type,
        "autopilot": hb.autopilot,
        "base_mode": hb.base_mode,
        "custom_mode": hb.custom_mode,
        "system_status": hb.system_status,
    }


def _metadata(link: Probe) -> dict[str, Any]:
    """PX4's parameter metadata (defaults, ranges), read over MAVLink FTP."""
    from pymavlink import mavftp

    data = mavftp.MAVFTP(link.conn, *link.target).read("/etc/extras/parameters.json.xz", 1 << 22)
    if not data:
        return {}
    meta = json.loads(lzma.decompress(data))
    out = {}
    for p in meta["parameters"]:
        entry = {"default": p.get("default"), "type": p.get("type")}
        for key in ("min", "max", "units"):
            if key in p:
                entry[key] = p[key]
        out[p["name"]] = entry
    return out


def record(
    port: int,
    *,
    peer: int | None = None,
    metadata: bool = False,
    timeout: float = 300.0,
    alive: Callable[[], bool] | None = None,
) -> dict[str, Any]:
    """Ask the autopilot linked to UDP ``port`` every question; its answers (JSON-able).

    ``peer``: the autopilot's own UDP port, to say hello to first (PX4's API link).
    ``timeout``: wall seconds any one wait may take; ``alive``: whether the autopilot still
    runs (a wait raises ``AutopilotStalled`` once it does not, or once its
    clock has not moved for ``STALL`` wall seconds).
    """
    link = Probe(port, timeout, peer, alive=alive)
    try:
        hb = link.wait(lambda m: m.get_type() == "HEARTBEAT", 30.0)
        assert hb is not None, "no HEARTBEAT within 30 s"
        # Ready: position and home known.
        link.wait(lambda m: m.get_type() == "HOME_POSITION", 60.0)
        out: dict[str, Any] = {"heartbeat": _heartbeat(hb)}
        out["streams"] = _streams(link)
        out.update(_params(link))
        out["param answers"] = _param_answers(link)
        out["commands"] = _commands(link)
        out["modes"] = _modes(link)
        out["missions"] = _missions(link)
        out["mission items"] = item_answers(link)
        out["flight"] = flight(link)
        if metadata:
            meta = _metadata(link)
            for name, entry in out["params"].items():
                entry.update({k: v for k, v in meta.get(name, {}).items() if k != "type"})
        return out
    finally:
        link.close()


def load(version: str = PX4_VERSION) -> dict[str, Any]:
    """The recorded answers of real PX4 ``version``."""
    text = resources.files(__package__).joinpath(f"data/px4-{version}.json").read_text()
    data: dict[str, Any] = json.loads(text)
    return data


def differences(expected: dict[str, Any], actual: dict[str, Any]) -> list[str]:
    """Where ``actual`` answers differently from ``expected`` (empty: conformant)."""
    out: list[str] = []
    for key in ("type", "autopilot"):
        want, got = expected["heartbeat"][key], actual["heartbeat"][key]
        if want != got:
            out.append(f"heartbeat {key}: {got}, PX4 {want}")
    from ..mavlink.dialect import dialect

    common = {cls.msgname for cls in dialect().mavlink_map.values()}
    for name, rate in expected["streams"].items():
        if name not in common:
            continue  # outside the common dialect (CURRENT_MODE): not ours to send
        got = actual["streams"].get(name)
        if got is None:
            out.append(f"stream {name} ({rate} Hz) not sent")
        elif abs(got - rate) > max(0.5, 0.25 * rate):
            out.append(f"stream {name}: {got} Hz, PX4 {rate} Hz")
    # (PX4's param_count counts the parameters in use when it answers, which can grow
    # during a listing: the names are compared, not the count.)
    for name in sorted(set(actual["params"]) - set(expected["params"])):
        out.append(f"parameter {name}: PX4 has none")
    for name, p in expected["params"].items():
        q = actual["params"].get(name)
        if q is None:
            out.append(f"parameter {name} missing")
        elif q["type"] != p["type"]:
            out.append(f"parameter {name} type {q['type']} != {p['type']}")
        elif not _close(q["value"], p["value"]):
            out.append(f"parameter {name} = {q['value']}, PX4 {p['value']}")
    for section in ("param answers", "commands", "modes", "missions"):
        for key, want in expected[section].items():
            got = actual[section].get(key)
            if isinstance(want, dict) and "ack" in want:
                # Which request kinds an upload saw depends on timing; the outcome does not.
                want, got = want["ack"], (got or {}).get("ack")
            if got != want:
                out.append(f"{section} / {key}: {got!r}, PX4 {want!r}")
    for key, want in expected.get("mission items", {}).items():
        got = actual.get("mission items", {}).get(key)
        if got != want:
            out.append(f"mission items / {key}: {got!r}, PX4 {want!r}")
    out += flight_differences(expected.get("flight", {}), actual.get("flight", {}))
    return out


def _close(a: float, b: float) -> bool:
    return a == b or (math.isfinite(a) and math.isfinite(b) and abs(a - b) <= 1e-4 * max(1, abs(b)))
