"""The simulator end of ArduPilot's JSON physics interface, in lockstep, and its MAVLink link.

ArduPilot SITL with ``--model JSON`` sends one servo packet per physics step over UDP (magic
18458, the frame rate it asks for, a frame count, 16 PWM outputs) and blocks until the
simulator answers it with one JSON line of the vehicle's state: time, body gyro and specific
force (FRD), position and velocity (NED, from home) and attitude. It resends the same packet
after a second without an answer, and its frame count starts again from 0 when it restarts.

``JsonBridge`` is that simulator end for our MuJoCo worlds, as a participant stepped
right after the world, every physics period: it answers ArduPilot's pending servo packet
with the world's latest ``Truth`` (stamped with the simulated
time), waits for the next packet (``lockstep_timeout`` of wall time, ArduPilot's liveness
checked meanwhile) and publishes its outputs (``ServoOutputs``) for the world's next
step. Each packet is answered once: copies ArduPilot resent while the simulation was busy
elsewhere are dropped (a second answer would be read as the next frame's); a packet repeated
a second after our answer (the answer was lost) is answered again without advancing; a
decreasing frame count is ArduPilot restarting, an error naming it. ArduPilot's clock is
the world's: a run is as fast as ArduPilot and the world compute.

The same participant carries ArduPilot's MAVLink link: ArduPilot connects to it as a TCP
client (``--serial0 tcpclient:HOST:PORT``), and the bridge moves whole MAVLink frames
between that connection and the uplink/downlink topics every step, so a ground station on
the topics talks to ArduPilot in simulated time. Traffic from anyone but the ArduPilot it
serves is ignored: on this host, only sockets of ArduPilot's own process are answered; in a
container, the simulation's network is ArduPilot's alone.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import socket
import struct
import time
from collections.abc import Callable
from pathlib import Path

import msgspec

from ..core.errors import MulticosimError, NodeCrashedError
from ..local import Watch, mark_reported
from ..mavlink.hil import MavlinkPacket, Truth
from ..mavlink.lockstep import RECV, FirstMavlinkClient, Lockstep
from ..runtime.context import StepContext, Subscription

__all__ = [
    "DOWNLINK",
    "MAGIC16",
    "MAGIC32",
    "SERVO_TOPIC",
    "TRUTH_TOPIC",
    "UPLINK",
    "JsonBridge",
    "MavlinkFramer",
    "ServoOutputs",
    "json_state",
    "process_ports",
]

log = logging.getLogger(__name__)

TRUTH_TOPIC = "ardupilot/truth"
"""Where the world publishes its true state every physics frame (what the bridge sends)."""
SERVO_TOPIC = "ardupilot/servos"
"""Where the bridge publishes ArduPilot's servo outputs (what the world applies)."""
UPLINK, DOWNLINK = "ardupilot/mavlink/up", "ardupilot/mavlink/down"
"""ArduPilot's MAVLink link as topics: to ArduPilot, and from it."""

MAGIC16, MAGIC32 = 18458, 29569
"""Servo packet magic numbers: 16 outputs (40 bytes), 32 outputs (72 bytes)."""
_HEADER = struct.Struct("<HHI")
_SIZES = {MAGIC16: 40, MAGIC32: 72}
RESEND_AFTER = 0.9  # s: ArduPilot resends a packet after a second without an answer


class ServoOutputs(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """ArduPilot's servo outputs for one physics step: PWM in microseconds (0: not driven)."""

    frame_count: int
    frame_rate: int
    pwm: tuple[int, ...]


def json_state(time_s: float, t: Truth) -> bytes:
    """The JSON line answering a servo packet with the state ``t`` at ``time_s``.

    ArduPilot's parser is a substring search with ``sscanf``: no blank after a key's colon,
    one object per line, framed by newlines. ``no_time_sync`` keeps ArduPilot from pacing
    itself to wall time: lockstep is the only pace.
    """
    return (
        f'\n{{"timestamp":{time_s!r},"imu":{{"gyro":[{t.rollspeed!r},{t.pitchspeed!r},'
        f'{t.yawspeed!r}],"accel_body":[{t.xacc!r},{t.yacc!r},{t.zacc!r}]}},'
        f'"position":[{t.north!r},{t.east!r},{t.down!r}],'
        f'"quaternion":[{t.qw!r},{t.qx!r},{t.qy!r},{t.qz!r}],'
        f'"velocity":[{t.vn!r},{t.ve!r},{t.vd!r}],"no_time_sync":1}}\n'
    ).encode()


class MavlinkFramer:
    """Cuts a MAVLink byte stream (TCP) into whole frames; bytes between frames are dropped."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> bytes:
        """The whole frames completed by ``data``, concatenated (partial ones are kept)."""
        buf = self._buf
        buf += data
        out = bytearray()
        i, n = 0, len(buf)
        while i < n:
            magic = buf[i]
            if magic == 0xFD:
                if i + 3 > n:
                    break
                size = buf[i + 1] + 12 + (13 if buf[i + 2] & 1 else 0)
            elif magic == 0xFE:
                if i + 2 > n:
                    break
                size = buf[i + 1] + 8
            else:
                i += 1  # not a frame start: resynchronise on the next magic byte
                continue
            if i + size > n:
                break
            out += buf[i : i + size]
            i += size
        del buf[:i]
        return bytes(out)


def process_ports(pid: int) -> set[tuple[str, int]]:
    """The (protocol, local port) of every IPv4 socket process ``pid`` holds (Linux /proc)."""
    inodes = set()
    with contextlib.suppress(OSError):
        for fd in os.scandir(f"/proc/{pid}/fd"):
            with contextlib.suppress(OSError):
                target = os.readlink(fd.path)
                if target.startswith("socket:["):
                    inodes.add(target[8:-1])
    ports: set[tuple[str, int]] = set()
    for proto in ("tcp", "udp"):
        with contextlib.suppress(OSError):
            lines = Path(f"/proc/{pid}/net/{proto}").read_text().splitlines()[1:]
            for line in lines:
                fields = line.split()
                if len(fields) > 9 and fields[9] in inodes:
                    ports.add((proto, int(fields[1].split(":")[1], 16)))
    return ports


PeerCheck = Callable[[str, tuple[str, int]], bool]
"""Whether a packet or connection (``"udp"``/``"tcp"``, source address) is ArduPilot's."""


class JsonBridge(Lockstep):
    """A participant serving ArduPilot's JSON physics interface and MAVLink link in lockstep."""

    def __init__(
        self,
        *,
        name: str,
        period: float,
        physics: socket.socket,
        mavlink: socket.socket,
        truth: str,
        servos: str,
        uplink: str,
        downlink: str,
        lockstep_timeout: float = 30.0,
    ) -> None:
        self.name = name
        self.period = period
        self.lockstep_timeout = lockstep_timeout
        self.topics = (truth, servos, uplink, downlink)
        physics.setblocking(False)
        self._physics = physics
        self.mavlink_port = int(mavlink.getsockname()[1])
        """The TCP port ArduPilot's MAVLink link connects to."""
        self._peer: tuple[str, int] | None = None
        self._pending: tuple[int, int, tuple[int, ...]] | None = None  # count, rate, pwm
        self._answered: int | None = None  # frame count of the last packet answered
        self._last_reply = b""
        self._answered_at = 0.0  # wall time of the last answer
        self._link: socket.socket | None = None
        self._clients = FirstMavlinkClient(mavlink, name, "MAVLink client", "ardupilotmega")
        self._framer = MavlinkFramer()
        self._pending_down = b""  # frames a client sent while it was being identified
        self._truth: Subscription[Truth] | None = None
        self._up: Subscription[MavlinkPacket] | None = None
        self._backlog: list[bytes] = []  # uplink sent before ArduPilot's link is known
        self.watch: Watch | None = None
        self.peer_check: PeerCheck | None = None
        self.frames = 0  # servo packets answered
        self.resends = 0  # repeated frame counts answered again (an answer was lost)
        self.stale = 0  # copies ArduPilot resent before our answer reached it (dropped)
        self.ignored = 0  # datagrams that were not ArduPilot's servo packets
        self.wait_s = 0.0  # wall time spent waiting for ArduPilot (what ArduPilot costs)

    @property
    def physics_port(self) -> int:
        """The UDP port ArduPilot sends its servo packets to."""
        return int(self._physics.getsockname()[1])

    @property
    def linked(self) -> bool:
        """Whether ArduPilot's MAVLink link is connected and has spoken MAVLink."""
        return self._link is not None

    @property
    def started(self) -> bool:
        """Whether ArduPilot has sent its first servo packet."""
        return self._pending is not None or self._answered is not None

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the world's truth and the ground station's uplink."""
        truth, _, uplink, _ = self.topics
        self._truth = ctx.subscribe(truth, Truth)
        self._up = ctx.subscribe(uplink, MavlinkPacket)

    # -- servo packets ------------------------------------------------------------------------

    def _read_packet(self) -> tuple[int, int, tuple[int, ...]] | None:
        """One servo packet from ArduPilot if one is waiting (others' datagrams dropped)."""
        while True:
            try:
                data, addr = self._physics.recvfrom(1024)
            except (BlockingIOError, InterruptedError):
                return None
            except ConnectionRefusedError:  # an ICMP error from an earlier send: no data
                continue
            if len(data) < 8:
                self.ignored += 1
                continue
            magic, rate, count = _HEADER.unpack_from(data)
            size = _SIZES.get(magic)
            if size is None or len(data) != size:
                self.ignored += 1
                continue
            if self._peer is None:
                if self.peer_check is not None and not self.peer_check("udp", addr):
                    self.ignored += 1
                    continue
                self._peer = addr
            elif addr != self._peer:
                self.ignored += 1
                continue
            return count, rate, struct.unpack_from(f"<{(size - 8) // 2}H", data, 8)

    def poll_started(self) -> bool:
        """Take ArduPilot's MAVLink connection and first servo packet if they are there."""
        self._accept()
        if self._pending is None and self._answered is None:
            self._pending = self._read_packet()
        return self.started

    def step(self, ctx: StepContext) -> None:
        """Answer ArduPilot's pending packet with the state now, wait for the next one."""
        self._accept()
        self._send_uplink()
        truth = self._truth.latest if self._truth is not None else None
        if truth is None or not self.poll_started():
            # ArduPilot is not stepping yet (or there is no state to send): nothing to answer.
            self._read_downlink(ctx)
            return
        pending = self._pending
        reply = json_state(ctx.time, truth)
        start = time.monotonic()
        try:
            if pending is not None:
                self._drop_resent(pending[0])
                self._answer(pending[0], reply)
            packet = self._await_packet()
        finally:
            # From the answer to the next packet: ArduPilot's frame (and, on a busy machine,
            # the wait for a core to run it on).
            self.wait_s += time.monotonic() - start
        self._pending = packet
        count, rate, pwm = packet
        ctx.publish(self.topics[1], ServoOutputs(count, rate, pwm))
        # Everything ArduPilot sent during that frame is in before its next servo packet.
        self._read_downlink(ctx)

    def _drop_resent(self, count: int) -> None:
        """Drop the copies of packet ``count`` ArduPilot resent while it waited for us.

        ArduPilot reads one answer per frame: a second answer to one packet would be read
        as the next frame's, and every answer after it one frame late.
        """
        while (packet := self._read_packet()) is not None:
            if packet[0] < count:
                raise self._restarted(count, packet[0])
            self.stale += 1

    def _answer(self, count: int, reply: bytes) -> None:
        assert self._peer is not None
        with contextlib.suppress(OSError):
            self._physics.sendto(reply, self._peer)
        self._answered = count
        self._answered_at = time.monotonic()
        self._last_reply = reply
        self.frames += 1

    def _await_packet(self) -> tuple[int, int, tuple[int, ...]]:
        deadline = time.monotonic() + self.lockstep_timeout
        physics = [self._physics]
        while True:
            # Short slices: an ArduPilot that exits is noticed at once, not after the timeout.
            ready, _, _ = select.select(physics, [], [], 0.2)
            packet = self._read_packet() if ready else None
            if packet is None:
                if time.monotonic() > deadline:
                    raise self._silent("servo packet")
                self._check_alive()
                continue
            count = packet[0]
            answered = self._answered
            if answered is None or count > answered:
                return packet
            if count < answered:
                raise self._restarted(answered, count)
            if time.monotonic() - self._answered_at < RESEND_AFTER:
                # Sent before our answer reached it: it has that answer now.
                self.stale += 1
                continue
            # ArduPilot waited a second after our answer and resent the packet: the answer
            # was lost. Answer again: the same state, time not advanced.
            self.resends += 1
            self._answered_at = time.monotonic()
            with contextlib.suppress(OSError):
                assert self._peer is not None
                self._physics.sendto(self._last_reply, self._peer)

    def _where(self) -> str:
        return f"physics frame {self.frames}"

    def _restarted(self, answered: int, count: int) -> MulticosimError:
        tail = ""
        if self.watch is not None:
            mark_reported(self.watch)
            tail = self.watch.log_tail()
        return NodeCrashedError(
            self.name,
            f"restarted: its frame count went back from {answered} to {count} (a reboot, or "
            "another ArduPilot sending to this simulator's port)",
            log_tail=tail,
        )

    # -- MAVLink ------------------------------------------------------------------------------

    def _accept(self) -> None:
        if self._link is not None:
            return
        client = self._clients.poll(self.peer_check)
        if client is not None:
            # ArduPilot is connected: nobody else gets in (nothing listens any more).
            self._clients.close()
            self._link = client.conn
            self._pending_down = self._framer.feed(client.data)

    def _send_uplink(self) -> None:
        """Send the ground station's frames to ArduPilot (held until its link is known)."""
        up = self._up
        if up is not None and up.fresh:
            self._backlog.extend(p.data for p in up.messages)
        link = self._link
        if link is not None and self._backlog:
            data, self._backlog = b"".join(self._backlog), []
            try:
                link.sendall(data)
            except OSError as exc:
                raise self._lost(f"closed its MAVLink connection ({exc})") from exc

    def _read_downlink(self, ctx: StepContext) -> None:
        """Publish the whole MAVLink frames ArduPilot has sent."""
        link = self._link
        if link is None:
            return
        chunks = [self._pending_down]
        self._pending_down = b""
        while True:
            try:
                data = link.recv(RECV)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:
                raise self._lost(f"closed its MAVLink connection ({exc})") from exc
            if not data:
                raise self._lost("closed its MAVLink connection")
            chunks.append(self._framer.feed(data))
        frames = b"".join(chunks)
        if frames:
            ctx.publish(self.topics[3], MavlinkPacket(frames))

    # -- stopping -----------------------------------------------------------------------------

    def idle(self, stopped: Callable[[], bool], timeout: float) -> None:
        """Answer servo packets (time advancing, the world frozen) until ``stopped()``.

        ArduPilot looks at its stop request (SIGTERM) only between physics steps: while it
        waits for an answer it cannot exit. Called from the thread that stops it.
        """
        deadline = time.monotonic() + timeout
        truth = self._truth.latest if self._truth is not None else None
        t = truth.time if truth is not None else 0.0
        while not stopped() and time.monotonic() < deadline and truth is not None:
            try:
                packet = self._read_packet()
            except OSError:
                return
            if packet is None:
                with contextlib.suppress(OSError, ValueError):
                    select.select([self._physics], [], [], 0.05)
                continue
            t += self.period
            self._answer(packet[0], json_state(t, truth))

    def close(self) -> None:
        """Close every socket."""
        self._clients.close()
        if self._link is not None:
            with contextlib.suppress(OSError):
                self._link.close()
        self._link = None
        self._physics.close()

    def __repr__(self) -> str:
        state = "stepping" if self.started else "waiting"
        return (
            f"JsonBridge({self.name!r}, UDP {self.physics_port}, TCP {self.mavlink_port}, {state})"
        )
