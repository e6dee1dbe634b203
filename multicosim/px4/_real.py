"""The real-PX4 path: PX4 SITL (a binary or an image) on our world and ground station.

PX4 SITL's simulator interface (``simulator_mavlink``) connects as a TCP client to the
simulator on port 4560, receives HIL_SENSOR / HIL_GPS and answers each sensor step with
HIL_ACTUATOR_CONTROLS; with lockstep its clock follows the sensors' timestamps.
:class:`HilTcpBridge` is that simulator end for our world: a participant that serves TCP,
forwards the world's sensor topics as MAVLink frames and waits, in lockstep, for PX4's
actuator outputs, which it publishes on the world's actuator topic. PX4's ground-station
side (UDP, it sends to 14540) is carried by :class:`~multicosim.px4._sitl.UdpBridge`, so the
same :mod:`._gcs` ground station drives real PX4 and our autopilot alike.

Verified here: the bridge's lockstep protocol against a MAVLink peer over real TCP
(``tests/px4/test_real.py``). Not verifiable here (no PX4 SITL can be obtained on our
machines): the PX4 binary/image launch itself; those tests skip with that reason.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import shlex
import socket
import time
from typing import Any

from .._errors import ConfigurationError, NodeTimeoutError
from .._interfaces import Node
from .._local import (
    InProcessFirmwareComponent,
    LocalEnvironment,
    ParticipantComponent,
    ProcessComponent,
    ProcessSimulator,
)
from .._runtime import StepContext, Subscription
from ._config import MuJoCo, Topics
from ._gcs import GcsSpec, ground_station
from ._hil import (
    HilActuatorControls,
    HilGps,
    HilSensor,
    MavlinkPacket,
    Wire,
    from_mavlink,
    pack,
)
from ._mav import new_link
from ._simulator import PX4Node, WorldComponent
from ._sitl import Link, UdpBridge

__all__ = ["HilTcpBridge", "RealPX4Component", "real_px4_simulator"]

log = logging.getLogger(__name__)

SIM_PORT = 4560


class HilTcpBridge:
    """A participant serving PX4's simulator interface over TCP, in lockstep."""

    def __init__(
        self,
        topics: Topics | None = None,
        *,
        period: float = 0.004,
        host: str = "127.0.0.1",
        port: int = SIM_PORT,
        lockstep_timeout: float = 5.0,
        wire: Wire = "mavlink",
    ) -> None:
        self.period = period
        self.wire = wire
        self.topics = topics or Topics()
        self.lockstep_timeout = lockstep_timeout
        self._server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._server.bind((host, port))
        self._server.listen(1)
        self._server.setblocking(False)
        self._conn: socket.socket | None = None
        self._mav: Any = new_link(0, 0)
        self._subs: list[Subscription[Any]] = []
        self.steps = 0
        self.replies = 0

    @property
    def port(self) -> int:
        """The TCP port PX4 should connect to."""
        return int(self._server.getsockname()[1])

    @property
    def connected(self) -> bool:
        """Whether a PX4 is connected."""
        return self._conn is not None

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the world's sensor topics (either wire)."""
        t = self.topics
        for topic in dict.fromkeys((t.imu, t.mag, t.baro, t.gps)):
            tp: type[Any] = MavlinkPacket
            if self.wire == "native":
                tp = HilGps if topic == t.gps else HilSensor
            self._subs.append(ctx.subscribe(topic, tp))

    def _accept(self) -> None:
        try:
            conn, peer = self._server.accept()
        except (BlockingIOError, InterruptedError):
            return
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn.settimeout(self.lockstep_timeout)
        self._conn = conn
        log.info("PX4 connected from %s", peer)

    def step(self, ctx: StepContext) -> None:
        """Send this step's sensors to PX4, wait for its actuator outputs, publish them."""
        if self._conn is None:
            self._accept()
            if self._conn is None:
                return
        frames = b"".join(
            (p if isinstance(p, MavlinkPacket) else pack(p)).data
            for sub in self._subs
            for p in sub.messages
        )
        if not frames:
            return
        self.steps += 1
        try:
            self._conn.sendall(frames)
            controls = self._await_controls()
        except OSError as exc:
            log.warning("PX4 link lost: %s", exc)
            with contextlib.suppress(OSError):
                self._conn.close()
            self._conn = None
            return
        self.replies += 1
        ctx.publish(self.topics.actuators, pack(controls) if self.wire == "mavlink" else controls)

    def _await_controls(self) -> HilActuatorControls:
        conn = self._conn
        assert conn is not None
        deadline = time.monotonic() + self.lockstep_timeout
        while time.monotonic() < deadline:
            data = conn.recv(65536)
            if not data:
                raise ConnectionResetError("PX4 closed the simulator connection")
            for m in self._mav.parse_buffer(data) or ():
                hil = from_mavlink(m)
                if isinstance(hil, HilActuatorControls):
                    return hil
        raise NodeTimeoutError(
            "px4", f"sent no HIL_ACTUATOR_CONTROLS within {self.lockstep_timeout:g} s (lockstep)"
        )

    def close(self) -> None:
        """Close the sockets."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        self._server.close()


@dataclasses.dataclass(frozen=True)
class RealPX4Component:
    """PX4 SITL from a binary or an image, with the bridges and our ground station.

    ``binary``: path of PX4's ``px4`` (run as ``px4 -d ROOTFS`` with ``PX4_SIM_MODEL``);
    ``image``: an image built from ``images/px4/Dockerfile`` (run with host networking).
    """

    binary: str | None = None
    image: str | None = None
    rootfs: str | None = None
    model: str = "none_iris"
    world: MuJoCo = dataclasses.field(default_factory=MuJoCo)
    name: str = "px4"
    sim_port: int = SIM_PORT
    api_port: int = 14540

    def __post_init__(self) -> None:
        if bool(self.binary) == bool(self.image):
            raise ConfigurationError("binary", self.binary, "exactly one of binary= or image=")

    def command(self) -> list[str]:
        """The command that starts PX4 SITL."""
        if self.image:
            return [
                "docker",
                "run",
                "--rm",
                "--init",
                "--network",
                "host",
                "-e",
                f"PX4_SIM_MODEL={self.model}",
                self.image,
            ]
        assert self.binary is not None
        rootfs = self.rootfs or os.path.join(os.path.dirname(self.binary), "..", "etc")
        return [self.binary, "-d", rootfs]

    def start(self, environment: LocalEnvironment) -> PX4Node:
        """Start the bridges, PX4 and the ground station (stopped in reverse order)."""
        topics = self.world.topics
        sim_port = self.sim_port
        uplink, downlink = f"{self.name}/mavlink/up", f"{self.name}/mavlink/down"
        started: list[tuple[str, Node]] = []
        try:
            started.append(
                (
                    f"{self.name}.hil",
                    ParticipantComponent(
                        lambda: HilTcpBridge(topics, period=self.world.period, port=sim_port),
                        f"{self.name}.hil",
                    ).start(environment),
                )
            )
            started.append(
                (
                    f"{self.name}.udp",
                    ParticipantComponent(
                        lambda: UdpBridge(
                            [Link(self.api_port + 40, self.api_port)], uplink, downlink, 0.01
                        ),
                        f"{self.name}.udp",
                    ).start(environment),
                )
            )
            env = {"PX4_SIM_MODEL": self.model, "PX4_SIM_HOSTNAME": "127.0.0.1"}
            started.append(
                (
                    self.name,
                    ProcessComponent(
                        shlex.join(self.command()), name=self.name, env=env, ready="started"
                    ).start(environment),
                )
            )
            gcs = InProcessFirmwareComponent(
                ground_station(
                    GcsSpec(
                        uplink=uplink,
                        downlink=downlink,
                        truth=topics.truth,
                        preflight_timeout=120.0,
                    ),
                    f"{self.name}.gcs",
                ),
                name=f"{self.name}.gcs",
            ).start(environment)
        except BaseException:
            _NodeGroup(started).stop()
            raise
        from ._simulator import PX4Component

        return PX4Node(
            self.name, gcs, _NodeGroup(started), PX4Component(self.world, "medium", name=self.name)
        )


class _NodeGroup:
    """Several nodes stopped as one, in reverse start order."""

    def __init__(self, nodes: list[tuple[str, Node]]) -> None:
        self._nodes = nodes

    def stop(self) -> None:
        from .._simulation import stop_all

        nodes, self._nodes = self._nodes, []
        stop_all([(name, node.stop) for name, node in reversed(nodes)], "the real-PX4 nodes")


def real_px4_simulator(
    *,
    binary: str | None = None,
    image: str | None = None,
    world: MuJoCo | None = None,
    seed: int = 0,
) -> tuple[ProcessSimulator, Any]:
    """A simulator with our MuJoCo world (MAVLink wire) and a real PX4 SITL, in real time.

    Returns the simulator and the PX4 node id (``simulation.get(id).send(Configuration)``).
    """
    world = world or MuJoCo()
    sim = ProcessSimulator(seed=seed, realtime=1.0)
    sim.add(WorldComponent(world, "medium", process=True))
    node_id = sim.add(RealPX4Component(binary=binary, image=image, world=world))
    return sim, node_id
