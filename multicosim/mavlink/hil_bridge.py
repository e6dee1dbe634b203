"""The simulator end of PX4's simulator interface (``simulator_mavlink``), in lockstep.

PX4 SITL connects as a TCP client to its simulator on port 4560 + instance and waits for
sensors: its clock is the ``time_usec`` of each HIL_SENSOR, and it answers every IMU sample
with HIL_ACTUATOR_CONTROLS once its controllers have run on it (lockstep). It also asks for
HIL_STATE_QUATERNION (ground truth) with a SET_MESSAGE_INTERVAL command.

:class:`HilTcpBridge` is that simulator end for our worlds, as a participant stepped right
after the world: each step it sends what the world (or an injector in front of PX4) published
on the sensor topics, waits for PX4's motor outputs and publishes them on the actuator topic,
so the world applies them at its next step. Before PX4's first answer (it is still starting
its modules) a step waits only briefly, so the start-up is paced but never blocks; from the
first answer on, every step waits for its answer (``lockstep_timeout`` of wall time, then an
error naming PX4 with its output tail, as does PX4 exiting or closing the connection).

A connection that does not speak MAVLink is closed, so a stray local client cannot take
PX4's place.
"""

from __future__ import annotations

import contextlib
import logging
import select
import socket
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import msgspec

from ..core.errors import MulticosimError, NodeCrashedError, NodeTimeoutError
from ..local import Watch, crashed, stalled
from ..runtime.context import StepContext, Subscription
from .dialect import CMD_SET_MSG_INTERVAL, MSG_HIL_STATE_QUATERNION, dialect, new_link
from .hil import (
    HilActuatorControls,
    HilGps,
    HilSensor,
    MavlinkPacket,
    Truth,
    Wire,
    from_mavlink,
    pack,
    unpack,
)
from .mission import Topics

__all__ = ["SIM_PORT", "FirstMavlinkClient", "HilTcpBridge", "Lockstep", "MavlinkClient"]

log = logging.getLogger(__name__)

SIM_PORT = 4560
"""PX4's simulator port for instance 0 (instance N connects to SIM_PORT + N)."""

HIL_CLOCK_START_US = 1_000_000
"""PX4's clock starts one second in, as under Gazebo, which has run before PX4 sees its first
sensor message: with a clock from zero, real PX4's local frame came out 0.6 m below where
its estimator later put the ground (a 10 m takeoff held at 9.4 m). Added to the simulated
time of everything sent to PX4."""

BOOT_WAIT = 0.05  # s of wall time a step waits for PX4 before its first answer
RECV = 65536  # bytes read from a socket at a time
_MAX_PREAMBLE = 600  # bytes a client may send before its first MAVLink frame (2 frames' worth)


def _on_px4_clock(msg: Any) -> Any:
    """``msg`` with its time on PX4's clock (HIL_CLOCK_START_US later)."""
    return msgspec.structs.replace(msg, time_usec=msg.time_usec + HIL_CLOCK_START_US)


def _parse(parser: Any, data: bytes) -> list[Any]:
    """The MAVLink messages in ``data`` (garbage, which pymavlink reports as BAD_DATA, left out)."""
    try:
        frames = parser.parse_buffer(data) or ()
    except Exception:  # pymavlink raises its own errors on garbage it cannot skip
        return []
    return [m for m in frames if m.get_type() != "BAD_DATA"]


class MavlinkClient(NamedTuple):
    """A client taken by :class:`FirstMavlinkClient`."""

    conn: socket.socket
    parser: Any
    data: bytes
    """Everything it sent so far (its first frames among it)."""
    frames: list[Any]
    """The MAVLink messages in ``data``."""


class FirstMavlinkClient:
    """The first client of a listening TCP socket that speaks MAVLink.

    A client is taken once it has sent a MAVLink frame; one that hangs up, or sends a few
    hundred bytes that hold none, is dropped, so a stray or hostile local client cannot
    take the firmware's place. ``what`` names the clients in the log.
    """

    def __init__(
        self,
        listener: socket.socket,
        name: str,
        what: str,
        dialect_name: str = "common",
    ) -> None:
        listener.setblocking(False)
        self.listener = listener
        self.name, self.what = name, what
        self._dialect = dialect_name
        self._pending: dict[socket.socket, tuple[Any, bytearray]] = {}

    def poll(self, peer_check: Callable[[str, Any], bool] | None = None) -> MavlinkClient | None:
        """Accept and read what is waiting; the client once one has spoken MAVLink.

        ``peer_check`` (transport, address) refuses clients outright.
        """
        with contextlib.suppress(BlockingIOError, InterruptedError):
            while True:
                conn, peer = self.listener.accept()
                if peer_check is not None and not peer_check("tcp", peer):
                    log.warning("%s: refused a %s from %s", self.name, self.what, peer)
                    conn.close()
                    continue
                conn.setblocking(False)
                self._pending[conn] = (new_link(0, 0, self._dialect), bytearray())
                log.debug("%s: %s from %s", self.name, self.what, peer)
        for conn, (parser, seen) in list(self._pending.items()):
            try:
                data = conn.recv(RECV)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                data = b""
            seen += data
            frames = _parse(parser, data) if data else []
            if not frames:
                if not data or len(seen) > _MAX_PREAMBLE:
                    del self._pending[conn]
                    conn.close()
                    if data:
                        log.warning("%s: dropped a %s that spoke no MAVLink", self.name, self.what)
                continue
            del self._pending[conn]
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return MavlinkClient(conn, parser, bytes(seen), frames)
        return None

    def close(self) -> None:
        """Close the clients still waiting and the listening socket."""
        for conn in self._pending:
            with contextlib.suppress(OSError):
                conn.close()
        self._pending = {}
        self.listener.close()


class Lockstep:
    """What a lockstep bridge to a firmware needs: the firmware's liveness and its errors.

    ``watch`` is the firmware's process or container (None: not watched); a bridge says
    where it is in the run (``_where``) for the errors.
    """

    name: str
    watch: Watch | None
    lockstep_timeout: float

    def _where(self) -> str:
        raise NotImplementedError

    def _check_alive(self) -> None:
        watch = self.watch
        if watch is not None and watch.poll() is not None:
            raise self._lost()

    def _lost(self, what: str = "") -> MulticosimError:
        """The error for a firmware that went away (``what`` it did: ``"closed the simulator
        connection"``), with how it ended, its exit code and output.

        A firmware that closes its connection is usually exiting: it gets a moment to do
        so, so that the error names its exit code. Marked as reported: stopping its process
        later does not raise the same crash again.
        """
        where = f"at {self._where()}"
        watch = self.watch
        if watch is None:
            return NodeCrashedError(self.name, f"{what or 'exited'} {where}")
        if watch.poll() is None:
            for _ in range(20):
                time.sleep(0.05)
                if watch.poll() is not None:
                    break
        return crashed(watch, where, f"it {what}" if what else "")

    def _silent(self, awaited: str) -> MulticosimError:
        return NodeTimeoutError(
            self.name,
            f"sent no {awaited} within {self.lockstep_timeout:g} s of wall time "
            f"(lockstep, {self._where()}){stalled(self.watch)}",
            log_tail=self.watch.log_tail() if self.watch is not None else "",
        )


class HilTcpBridge(Lockstep):
    """A participant serving PX4's simulator interface over TCP, in lockstep."""

    def __init__(
        self,
        topics: Topics | None = None,
        *,
        period: float = 0.004,
        host: str = "127.0.0.1",
        port: int = SIM_PORT,
        lockstep_timeout: float = 30.0,
        wire: Wire = "mavlink",
        name: str = "px4",
        server: socket.socket | None = None,
    ) -> None:
        self.period = period
        self.wire = wire
        self.name = name
        self.topics = topics or Topics()
        self.lockstep_timeout = lockstep_timeout
        if server is None:
            server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                server.bind((host, port))
                server.listen(4)
            except OSError:
                server.close()
                raise
        self._port = int(server.getsockname()[1])
        self._clients = FirstMavlinkClient(server, name, "simulator client")
        self._conn: socket.socket | None = None
        self._parser: Any = None
        self._link: Any = new_link(1, 51)  # what PX4's simulators call themselves
        self._d: Any = dialect()
        self._subs: list[Subscription[Any]] = []
        self._truth: Subscription[Truth] | None = None
        self._truth_interval: float | None = None
        self._next_truth = 0.0
        self.watch: Watch | None = None
        self.answering = False  # PX4 has answered a step: from now on, strict lockstep
        self.steps = 0
        self.replies = 0
        self.wait_s = 0.0  # wall time spent waiting for PX4's answers (what PX4 costs)

    @property
    def port(self) -> int:
        """The TCP port PX4 should connect to."""
        return self._port

    @property
    def connected(self) -> bool:
        """Whether PX4 is connected."""
        return self._conn is not None

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the sensor topics (either wire) and the world's truth."""
        t = self.topics
        for topic in dict.fromkeys((t.imu, t.mag, t.baro, t.gps)):
            tp: type[Any] = MavlinkPacket
            if self.wire == "native":
                tp = HilGps if topic == t.gps else HilSensor
            self._subs.append(ctx.subscribe(topic, tp))
        self._truth = ctx.subscribe(t.truth, Truth)

    # -- connection -------------------------------------------------------------------------

    def poll_connection(self) -> bool:
        """Accept PX4's connection if it is there; True once PX4 is connected.

        A client is taken for PX4 once it has sent a MAVLink frame (PX4 starts with a
        HEARTBEAT); one that sends a few hundred bytes that hold none, or hangs up, is dropped.
        """
        if self._conn is not None:
            return True
        client = self._clients.poll()
        if client is not None:
            # PX4 is connected: nobody else gets in (nothing listens any more).
            self._clients.close()
            self._parser = client.parser
            self._conn = client.conn
            log.info("%s connected to its simulator", self.name)
            self._handle(client.frames)
        return self._conn is not None

    def _handle(self, frames: list[Any]) -> HilActuatorControls | None:
        controls = None
        for m in frames:
            hil = from_mavlink(m)
            if isinstance(hil, HilActuatorControls):
                controls = hil
            elif (
                m.get_type() == "COMMAND_LONG"
                and m.command == CMD_SET_MSG_INTERVAL
                and round(m.param1) == MSG_HIL_STATE_QUATERNION
            ):
                # PX4 asks for ground truth every param2 microseconds (<= 0: stop).
                self._truth_interval = m.param2 * 1e-6 if m.param2 > 0 else None
        return controls

    # -- lockstep ---------------------------------------------------------------------------

    def step(self, ctx: StepContext) -> None:
        """Send this step's sensors to PX4, wait for its motor outputs, publish them."""
        if not self.poll_connection() or ctx.time_ns == 0:
            # PX4 takes the first sensor time as its clock's start: it must not be zero.
            return
        frames = [
            pack(_on_px4_clock(m)).data
            for sub in self._subs
            for p in sub.messages
            for m in (unpack(p) if isinstance(p, MavlinkPacket) else (p,))
        ]
        truth = self._ground_truth(ctx)
        if truth is not None:
            frames.append(truth)
        if not frames:
            return
        self.steps += 1
        conn = self._conn
        assert conn is not None
        data = b"".join(frames)
        start = time.monotonic()
        try:
            # Sending wakes PX4's threads (real-time priority where it may), which can run
            # before this call returns: what the step waits for PX4 starts here.
            conn.sendall(data)
            controls = self._receive_controls(conn, start)
        except OSError as exc:
            raise self._lost(f"closed the simulator connection ({exc})") from exc
        finally:
            self.wait_s += time.monotonic() - start
        if controls is None:
            return
        self.replies += 1
        ctx.publish(self.topics.actuators, pack(controls) if self.wire == "mavlink" else controls)

    def _ground_truth(self, ctx: StepContext) -> bytes | None:
        sub = self._truth
        if self._truth_interval is None or sub is None or sub.latest is None:
            return None
        if ctx.time < self._next_truth:
            return None
        self._next_truth = ctx.time + self._truth_interval
        t = sub.latest
        msg = self._d.MAVLink_hil_state_quaternion_message(
            ctx.time_ns // 1000 + HIL_CLOCK_START_US,
            [t.qw, t.qx, t.qy, t.qz],
            t.rollspeed,
            t.pitchspeed,
            t.yawspeed,
            round(t.lat * 1e7),
            round(t.lon * 1e7),
            round(t.alt * 1000),
            round(t.vn * 100),
            round(t.ve * 100),
            round(t.vd * 100),
            0,
            0,
            0,
            0,
            0,
        )
        data = bytes(msg.pack(self._link))
        self._link.seq = (self._link.seq + 1) & 0xFF
        return data

    def _receive_controls(self, conn: socket.socket, start: float) -> HilActuatorControls | None:
        wait = self.lockstep_timeout if self.answering else BOOT_WAIT
        deadline = start + wait
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                if not self.answering:
                    return None
                raise self._silent("HIL_ACTUATOR_CONTROLS")
            # Short slices: a PX4 that exits is noticed at once, not after the timeout.
            ready, _, _ = select.select([conn], [], [], min(left, 0.2))
            if not ready:
                self._check_alive()
                continue
            try:
                data = conn.recv(RECV)
            except OSError as exc:
                raise self._lost(f"closed the simulator connection ({exc})") from exc
            if not data:
                raise self._lost("closed the simulator connection")
            controls = self._handle(_parse(self._parser, data))
            if controls is not None:
                self.answering = True
                return controls

    def _where(self) -> str:
        return f"simulated step {self.steps}"

    def close(self) -> None:
        """Close the sockets."""
        self._clients.close()
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.close()
        self._conn = None

    def __repr__(self) -> str:
        state = "connected" if self._conn is not None else "waiting"
        return f"HilTcpBridge({self.name!r}, port {self.port}, {state})"
