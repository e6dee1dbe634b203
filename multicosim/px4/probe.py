"""A ground station's MAVLink link to an autopilot, timed on the autopilot's own clock.

``Probe`` is what ``conformance`` asks its questions with: a pymavlink UDP link
whose waits count the autopilot's simulated time (its ``time_boot_ms``), so that a sped-up or
slowed-down autopilot is asked the same way. A wait always ends: on simulated time, after
``timeout`` wall seconds, or with ``AutopilotStalled`` once the autopilot's clock has
not moved for ``stall`` wall seconds or the autopilot has exited.
"""

from __future__ import annotations

import socket
import struct
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from ..mavlink.dialect import (
    FRAME_LOCAL_NED,
    MAV_AUTOPILOT_INVALID,
    MAV_TYPE_GCS,
    TARGET_IGNORE_ACCEL,
    TARGET_IGNORE_VELOCITY,
    TARGET_IGNORE_YAW,
    TARGET_IGNORE_YAW_RATE,
)
from .modes import Mode, encode_custom_mode

__all__ = [
    "STALL",
    "AutopilotStalled",
    "Probe",
    "command_id",
    "int_bytes",
    "param_name",
    "param_value",
]

STALL = 30.0  # wall seconds without a later autopilot time before a wait gives up
SETPOINT_PERIOD_MS = 100  # offboard setpoints at 10 Hz of simulated time (PX4 wants > 2 Hz)


def command_id(name: str) -> int:
    """MAV_CMD_``name``'s number (``NAV_TAKEOFF``, ``COMPONENT_ARM_DISARM``, ...)."""
    from ..mavlink.dialect import dialect

    return int(getattr(dialect(), f"MAV_CMD_{name}"))


class AutopilotStalled(RuntimeError):
    """The autopilot's simulated clock stopped: no answer can come any more."""


class Probe:
    """A pymavlink UDP link with the autopilot's simulated clock (its time_boot_ms)."""

    def __init__(
        self,
        port: int,
        timeout: float,
        peer: int | None = None,
        stall: float = STALL,
        alive: Callable[[], bool] | None = None,
    ) -> None:
        from pymavlink import mavutil

        from ..mavlink.dialect import dialect

        # pymavlink shares the port (SO_REUSEADDR): another listener there would take some
        # of the autopilot's datagrams. Refuse a port that is taken.
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError as exc:
                raise RuntimeError(f"UDP port {port} is in use by another program") from exc
        self.conn: Any = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=245, source_component=190
        )
        # MAVLink 2 with the common dialect (mavutil's default is MAVLink 1, which has no
        # mission_type: fence and rally lists would arrive as missions).
        self.conn.mav = dialect().MAVLink(self.conn, srcSystem=245, srcComponent=190)
        self.conn.mav.robust_parsing = True
        # A sped-up autopilot streams thousands of datagrams a second: a deep receive buffer
        # keeps its answers from being dropped while this reader is descheduled.
        self.conn.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
        self.mav: Any = self.conn.mav
        self.peer = peer
        self._beat = 0.0
        self.sim_ms = 0
        self.timeout = timeout
        self.stall = stall
        # The autopilot's system id, from its first heartbeat (PX4 SITL instance N is N + 1).
        self.system: int | None = None
        self.counts: Counter[str] = Counter()
        self.last: dict[str, Any] = {}
        self.texts: list[str] = []
        # Sent every SETPOINT_PERIOD simulated seconds while set (offboard setpoints).
        self.stream: Callable[[], None] | None = None
        self._streamed = 0
        self.alive = alive

    def close(self) -> None:
        self.conn.close()

    @property
    def target(self) -> tuple[int, int]:
        """The autopilot's system and component, as messages to it address them."""
        return (self.system or 1, 1)

    def recv(self, wall: float = 0.2) -> Any:
        self._send_due()
        return self._note(self.conn.recv_match(blocking=True, timeout=wall))

    def _send_due(self) -> None:
        """What this ground station sends on its own: heartbeats and the setpoint stream."""
        if self.peer is not None and time.monotonic() - self._beat > 0.5:
            # A ground station's heartbeat to the autopilot's own port: PX4 then answers
            # this socket whatever its link was set to send to.
            self._beat = time.monotonic()
            beat = self.mav.heartbeat_encode(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 4)
            self.conn.port.sendto(beat.pack(self.mav), ("127.0.0.1", self.peer))
        if self.stream is not None and self.sim_ms - self._streamed >= SETPOINT_PERIOD_MS:
            self._streamed = self.sim_ms
            self.stream()

    def catch_up(self, wall: float = 10.0) -> None:
        """Read what is already waiting (for up to ``wall`` seconds).

        Called before a question: a reader that has fallen behind a sped-up autopilot would
        otherwise time the answer's window from its backlog's clock, not from the question,
        and close it on the backlog before the answer is read. On a loaded machine a reader
        at a tenth of the CPU it needs takes seconds to catch up, hence the generous bound.
        """
        limit = time.monotonic() + wall
        while time.monotonic() < limit:
            self._send_due()
            m = self.conn.recv_match(blocking=False)
            if m is None:
                return
            self._note(m)

    def _note(self, m: Any) -> Any:
        """``m`` after counting it and advancing the clock; None for what is not the autopilot's."""
        if m is None:
            return None
        name = m.get_type()
        if name == "BAD_DATA":
            return None
        if self.system is None and name == "HEARTBEAT" and m.autopilot != MAV_AUTOPILOT_INVALID:
            self.system = m.get_srcSystem()
        if self.system is not None and m.get_srcSystem() != self.system:
            return None
        t = getattr(m, "time_boot_ms", None)
        if isinstance(t, int) and t > self.sim_ms:
            self.sim_ms = t
        self.counts[name] += 1
        self.last[name] = m
        if name == "STATUSTEXT":
            self.texts.append(m.text)
        return m

    def wait(self, ok: Any, sim_s: float) -> Any:
        """The first message for which ``ok(m)``, within ``sim_s`` simulated seconds.

        None once ``sim_s`` have passed on the autopilot's clock (or ``timeout`` wall
        seconds, on a clock that crawls); ``AutopilotStalled`` when that clock has not
        moved for ``stall`` wall seconds: a lockstep autopilot whose simulation stopped
        sends no later time, and every later question would wait its full timeout.
        """
        start = self.sim_ms or None  # the clock starts with the first message
        now = time.monotonic()
        wall_deadline = now + self.timeout
        clock, moved = self.sim_ms, now
        while now < wall_deadline:
            m = self.recv()
            if m is not None and ok(m):
                return m
            now = time.monotonic()
            if self.alive is not None and not self.alive():
                raise AutopilotStalled(f"the autopilot exited (its clock at {self.sim_ms} ms)")
            if self.sim_ms != clock:
                clock, moved = self.sim_ms, now
            elif now - moved > self.stall:
                raise AutopilotStalled(
                    f"the autopilot's clock (time_boot_ms) stayed at {self.sim_ms} ms for "
                    f"{self.stall:g} s of wall time: its simulation is stalled or gone"
                )
            if start is None:
                start = self.sim_ms or None
            elif self.sim_ms - start >= sim_s * 1000:
                break
        return None

    def sleep(self, sim_s: float) -> None:
        self.wait(lambda m: False, sim_s)

    def command(self, name: str, *params: float, sim_s: float = 1.0) -> int | None:
        """COMMAND_LONG ``name``: its result, or None without an answer (asked three times)."""
        p = [*params, *[0.0] * (7 - len(params))]
        return self._ask(
            name, lambda cmd: self.mav.command_long_send(*self.target, cmd, 0, *p), sim_s
        )

    def command_int(self, name: str, frame: int, *params: float, sim_s: float = 1.0) -> int | None:
        """COMMAND_INT ``name`` (params 5 and 6 the integers x and y), as ``command``."""
        p = [*params, *[0.0] * (7 - len(params))]
        x, y = int(p[4]), int(p[5])
        return self._ask(
            name,
            lambda cmd: self.mav.command_int_send(
                *self.target, frame, cmd, 0, 0, p[0], p[1], p[2], p[3], x, y, p[6]
            ),
            sim_s,
        )

    def _ask(self, name: str, send: Callable[[int], None], sim_s: float) -> int | None:
        cmd = command_id(name)
        for _ in range(3):  # a datagram may be lost on a busy host
            self.catch_up()
            send(cmd)
            ack = self.wait(lambda m: m.get_type() == "COMMAND_ACK" and m.command == cmd, sim_s)
            if ack is not None:
                return int(ack.result)
        return None

    def custom_mode(self) -> int:
        hb = self.wait(lambda m: m.get_type() == "HEARTBEAT", 2.0)
        return -1 if hb is None else int(hb.custom_mode)

    def mode(self) -> list[int]:
        """The (main, sub) mode of the autopilot's next heartbeat."""
        from .modes import decode_custom_mode

        return list(decode_custom_mode(self.custom_mode()))

    def in_mode(self, mode: Mode, sim_s: float) -> bool:
        """Whether the autopilot reports ``mode`` within ``sim_s`` simulated seconds."""
        code = encode_custom_mode(*mode.value)
        hb = self.wait(lambda m: m.get_type() == "HEARTBEAT" and m.custom_mode == code, sim_s)
        return hb is not None

    def position(self) -> tuple[float, float, float]:
        """The autopilot's latest local position (NED, m)."""
        m = self.last.get("LOCAL_POSITION_NED")
        if m is None:
            m = self.wait(lambda m: m.get_type() == "LOCAL_POSITION_NED", 2.0)
        return (0.0, 0.0, 0.0) if m is None else (float(m.x), float(m.y), float(m.z))

    def collect(self, name: str, value: Callable[[Any], float], sim_s: float) -> list[float]:
        """``value`` of every ``name`` message over the next ``sim_s`` simulated seconds."""
        values: list[float] = []

        def note(m: Any) -> bool:
            if m.get_type() == name:
                values.append(value(m))
            return False

        self.wait(note, sim_s)
        return values

    def setpoints(self, pos: tuple[float, float, float]) -> Callable[[], None]:
        """A sender of offboard position setpoints at ``pos`` (local NED), for ``stream``."""
        mask = TARGET_IGNORE_VELOCITY | TARGET_IGNORE_ACCEL | TARGET_IGNORE_YAW
        mask |= TARGET_IGNORE_YAW_RATE

        def send() -> None:
            self.mav.set_position_target_local_ned_send(
                self.sim_ms, *self.target, FRAME_LOCAL_NED, mask, *pos, 0, 0, 0, 0, 0, 0, 0, 0
            )

        return send

    def upload(self, items: list[tuple[Any, ...]], mission_type: int = 0) -> dict[str, Any]:
        """Upload ``items`` (seq, frame, command, params 1-4, x, y, z each) as a list of
        ``mission_type``: the MISSION_ACK type (None: no answer) and the kinds of requests
        that asked for them."""
        self.catch_up()
        self.mav.mission_count_send(*self.target, len(items), mission_type)
        requests: list[str] = []
        kinds = ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK")
        for _ in range(4 * len(items) + 4):
            m = self.wait(lambda m: m.get_type() in kinds, 2.0)
            if m is None:
                break
            if m.get_type() == "MISSION_ACK":
                return {"ack": int(m.type), "requests": sorted(set(requests))}
            requests.append(m.get_type())
            s, frame, cmd, p1, p2, p3, p4, x, y, z = items[m.seq]
            self.mav.mission_item_int_send(
                *self.target, s, frame, cmd, int(s == 0), 1, p1, p2, p3, p4, x, y, z, mission_type
            )
        return {"ack": None, "requests": requests}

    def param(self, send: Callable[[], None]) -> dict[str, Any]:
        """The reply to a parameter read or set that ``send`` sends (retried, as ground
        stations do): its kind, name and value."""
        self.texts.clear()
        for _ in range(3):  # a datagram may be lost on a busy host
            self.catch_up()
            send()
            m = self.wait(lambda m: m.get_type() in ("PARAM_VALUE", "PARAM_ERROR"), 1.0)
            if m is not None:
                break
        else:
            return {"reply": None}
        out: dict[str, Any] = {"reply": m.get_type(), "name": param_name(m.param_id)}
        if m.get_type() == "PARAM_VALUE":
            out["value"] = param_value(m)
        return out


def param_value(m: Any) -> float | int:
    """A PARAM_VALUE's value as PX4 means it (integers are sent bytewise in the float)."""
    if m.param_type in (1, 2, 3, 4, 5, 6):
        raw = struct.pack("<f", m.param_value)
        fmt = {1: "<B", 2: "<b", 3: "<H", 4: "<h", 5: "<I", 6: "<i"}[m.param_type]
        size = struct.calcsize(fmt)
        return int(struct.unpack(fmt, raw[:size])[0])
    return float(m.param_value)


def int_bytes(value: int) -> float:
    """An integer parameter's value as PARAM_SET carries it (its bytes in the float)."""
    return float(struct.unpack("<f", struct.pack("<i", value))[0])


def param_name(raw: Any) -> str:
    """A parameter name as sent (NUL-padded bytes or text), as text."""
    text = raw.decode(errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.split("\0", 1)[0]
