"""The conformance recording's questions in the air, and how their answers are compared.

After the questions on the ground (``conformance``), ``flight`` flies: a takeoff to
10 m and the altitude held; DO_REPOSITION 30 m away while holding, without and with the
change-mode flag; offboard setpoints that stop (COM_OF_LOSS_T, then COM_OBL_RC_ACT's mode);
an offboard position setpoint 200 m away (the horizontal speed it is flown at:
MPC_XY_VEL_MAX's). Every wait is in the autopilot's simulated time. ``differences``
compares what was measured within ``TOLERANCES``, and everything else exactly.
"""

from __future__ import annotations

import math
from typing import Any

from ..mavlink.dialect import FRAME_GLOBAL_INT
from .modes import Mode, encode_custom_mode
from .probe import Probe, int_bytes

__all__ = ["TOLERANCES", "differences", "flight"]

TAKEOFF_ALT = 10.0  # m above home (MIS_TAKEOFF_ALT)
REACHED = 3.0  # m from a DO_REPOSITION target that counts as there
RCL_EXCEPT_OFFBOARD = 1 << 2  # COM_RCL_EXCEPT's bit for offboard
FAR = 200.0  # m east of the offboard setpoint whose speed is measured

TOLERANCES = {
    "altitude": 0.3,  # m: the altitude a 10 m takeoff holds
    "moved": 2.0,  # m: drift after the offboard setpoints stop (both hold where they are)
    "max horizontal speed": 1.0,  # m/s: MPC_XY_VEL_MAX (12 m/s), overshoot aside
}
"""How far a measurement may be from PX4's and still be the same outcome: the two autopilots
fly the same world, but their estimators and controllers are not the same code."""


def flight(probe: Probe) -> dict[str, Any]:
    """Fly, and record what the autopilot did (each a small dict of outcomes)."""
    nan = math.nan
    out: dict[str, Any] = {}
    offboard_ok = int_bytes(RCL_EXCEPT_OFFBOARD)
    to = probe.target
    # No RC in SITL: offboard is excepted from the RC-loss failsafe, as PX4's offboard tests do.
    probe.param(lambda: probe.mav.param_set_send(*to, b"COM_RCL_EXCEPT", offboard_ok, 6))
    probe.param(lambda: probe.mav.param_set_send(*to, b"MIS_TAKEOFF_ALT", TAKEOFF_ALT, 9))

    arm = probe.command("COMPONENT_ARM_DISARM", 1)
    takeoff = probe.command("NAV_TAKEOFF", nan, 0, 0, nan, nan, nan, nan)
    climbed = probe.wait(
        lambda m: (
            m.get_type() == "GLOBAL_POSITION_INT" and m.relative_alt >= (TAKEOFF_ALT - 0.5) * 1000
        ),
        40.0,
    )
    probe.sleep(10.0)  # settles
    alts = probe.collect("GLOBAL_POSITION_INT", lambda m: m.relative_alt / 1000, 2.0)
    out["takeoff to 10 m"] = {
        "arm": arm,
        "takeoff": takeoff,
        "climbed": climbed is not None,
        "altitude": round(sum(alts) / len(alts), 2) if alts else None,
    }

    # DO_REPOSITION 30 m north while in Hold (in the air), without the change-mode flag (as
    # PX4's in-place reposition test), then 30 m back with it (as ground stations send it).
    probe.in_mode(Mode.LOITER, 10.0)
    for key, flags, north in (("reposition in hold", 0, 30.0), ("reposition with mode", 1, -30.0)):
        out[key] = _reposition(probe, north, flags)
        probe.sleep(3.0)

    # Offboard, holding where it is; then the setpoints stop.
    probe.stream = probe.setpoints(probe.position())
    probe.sleep(1.0)
    result = probe.command("DO_SET_MODE", 1, *Mode.OFFBOARD.value)
    offboard = probe.in_mode(Mode.OFFBOARD, 2.0)
    probe.sleep(2.0)
    at = probe.position()
    probe.stream = None
    code = encode_custom_mode(*Mode.OFFBOARD.value)
    # Within COM_OF_LOSS_T, which grows with the speed the autopilot is paced at (at most 60 s).
    probe.wait(lambda m: m.get_type() == "HEARTBEAT" and m.custom_mode != code, 65.0)
    probe.sleep(3.0)
    out["offboard setpoints stop"] = {
        "result": result,
        "offboard": offboard,
        "mode": probe.mode(),
        "moved": round(_distance(probe.position(), at), 2),
    }

    # Offboard again, to a position setpoint far east: the horizontal speed flown.
    hold = probe.position()
    probe.stream = probe.setpoints(hold)
    probe.sleep(1.0)
    result = probe.command("DO_SET_MODE", 1, *Mode.OFFBOARD.value)
    offboard = probe.in_mode(Mode.OFFBOARD, 2.0)
    probe.stream = probe.setpoints((hold[0], hold[1] + FAR, hold[2]))
    speeds = probe.collect("LOCAL_POSITION_NED", lambda m: math.hypot(m.vx, m.vy), 10.0)
    probe.stream = None  # the fallback mode brakes and holds
    out["offboard far position"] = {
        "result": result,
        "offboard": offboard,
        "max horizontal speed": round(max(speeds), 2) if speeds else None,
    }
    return out


def differences(expected: dict[str, Any], actual: dict[str, Any]) -> list[str]:
    """Where ``actual``'s flight answers differ from ``expected``'s (within TOLERANCES)."""
    out: list[str] = []
    for key, answers in expected.items():
        flown = actual.get(key) or {}
        for name, want in answers.items():
            got = flown.get(name)
            tolerance = TOLERANCES.get(name)
            if tolerance is None or want is None or got is None:
                same = got == want
            else:
                same = abs(got - want) <= tolerance
            if not same:
                out.append(f"flight / {key} / {name}: {got!r}, PX4 {want!r}")
    return out


def _reposition(probe: Probe, north: float, flags: int) -> dict[str, Any]:
    """DO_REPOSITION ``north`` m (COMMAND_INT): its result, the mode a second later, and
    whether the vehicle came within REACHED m of the position (30 s)."""
    from ..core.geo import LocalProjection

    start = probe.position()
    here = probe.last.get("GLOBAL_POSITION_INT")
    if here is None:
        here = probe.wait(lambda m: m.get_type() == "GLOBAL_POSITION_INT", 2.0)
    if here is None:
        return {"result": None}
    lat, lon = LocalProjection(here.lat * 1e-7, here.lon * 1e-7).reproject(north, 0.0)
    alt = here.alt / 1000  # AMSL, as FRAME_GLOBAL_INT has it: the altitude it is at
    result = probe.command_int(
        "DO_REPOSITION", FRAME_GLOBAL_INT, -1, flags, 0, math.nan, lat * 1e7, lon * 1e7, alt
    )
    probe.sleep(1.0)
    mode = probe.mode()
    target = (start[0] + north, start[1])
    reached = probe.wait(
        lambda m: m.get_type() == "LOCAL_POSITION_NED" and _distance((m.x, m.y), target) <= REACHED,
        30.0,
    )
    return {"result": result, "mode": mode, "reached": reached is not None}


def _distance(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    """Horizontal distance between two local positions (m)."""
    return math.hypot(a[0] - b[0], a[1] - b[1])
