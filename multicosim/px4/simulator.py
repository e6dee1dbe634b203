"""The simulator end of PX4's simulator interface (``simulator_mavlink``), in lockstep.

PX4 SITL connects as a TCP client to its simulator on port 4560 + instance and waits for
sensors: its clock is the ``time_usec`` of each HIL_SENSOR, and it answers every IMU sample
with HIL_ACTUATOR_CONTROLS once its controllers have run on it (lockstep). It also asks for
HIL_STATE_QUATERNION (ground truth) with a SET_MESSAGE_INTERVAL command.

``HilTcpBridge`` is that simulator end for our worlds, as a participant stepped right
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
from typing import Any

import msgspec

from ..local import Watch
from ..mavlink.dialect import CMD_SET_MSG_INTERVAL, MSG_HIL_STATE_QUATERNION, dialect
from ..mavlink.hil import (
    HilActuatorControls,
    HilGps,
    HilSensor,
    MavlinkPacket,
    Packer,
    Truth,
    Wire,
    from_mavlink,
    unpack,
)
from ..mavlink.lockstep import RECV, FirstMavlinkClient, Lockstep, parse
from ..quadrotor.topics import Topics
from ..runtime.context import StepContext, Subscription

__all__ = ["BOOT_WAIT", "HIL_CLOCK_START_US", "SIM_PORT", "HilTcpBridge"]

log = logging.getLogger(__name__)

SIM_PORT = 4560
"""PX4's simulator port for instance 0 (instance N connects to SIM_PORT + N)."""

HIL_CLOCK_START_US = 1_000_000
"""PX4's clock starts one second in, as under Gazebo, which has run before PX4 sees its first
sensor message: with a clock from zero, real PX4's local frame came out 0.6 m below where
its estimator later put the ground (a 10 m takeoff held at 9.4 m). Added to the simulated
time of everything sent to PX4."""

BOOT_WAIT = 0.05  # s of wall time a step waits for PX4 before its first answer


def _on_px4_clock(msg: Any) -> Any:
    """``msg`` with its time on PX4's clock (HIL_CLOCK_START_US later)."""
    return msgspec.structs.replace(msg, time_usec=msg.time_usec + HIL_CLOCK_START_US)


class HilTcpBridge(Lockstep):
    """A participant serving PX4's simulator interface over TCP, in lockstep."""

    def __init__(
        self,
        topics: Topics | None = None,
        *,
        home_alt: float,
        period: float = 0.004,
        host: str = "127.0.0.1",
        port: int = SIM_PORT,
        lockstep_timeout: float = 30.0,
        wire: Wire = "mavlink",
        name: str = "px4",
        server: socket.socket | None = None,
    ) -> None:
        self.period = period
        self.home_alt = home_alt
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
        # One numbering for every frame PX4 gets; 51: what PX4's simulators call themselves.
        self._packer = Packer(1, 51)
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
            self._packer.pack(_on_px4_clock(m)).data
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
        ctx.publish(self.topics.actuators, self._packer.write(controls, self.wire))

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
            # HIL_STATE_QUATERNION's altitude is AMSL (PX4 passes it on as ground truth, as
            # MAVSDK's ground_truth reads it); the world's truth is above home.
            round((self.home_alt + t.alt) * 1000),
            round(t.vn * 100),
            round(t.ve * 100),
            round(t.vd * 100),
            0,
            0,
            0,
            0,
            0,
        )
        return self._packer.frame(msg)

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
            controls = self._handle(parse(self._parser, data))
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
