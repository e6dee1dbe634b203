"""MAVLink over UDP the way SITL firmware does it: links bound on the host, answering
whoever talks to them, carried onto an autopilot's topics.

Used by ``multicosim px4 sitl`` (ground stations and MAVSDK reach a simulated autopilot on
PX4's usual ports) and by the real-PX4 launcher (PX4's API link carried to our ground
station).
"""

from __future__ import annotations

import contextlib
import dataclasses
import socket

from ..runtime.context import StepContext, Subscription
from .hil import MavlinkPacket

__all__ = ["API_PORT", "GCS_PORT", "Link", "UdpBridge"]

GCS_PORT = 14550
"""Where SITL's ground-station link sends (QGroundControl listens here)."""
API_PORT = 14540
"""Where SITL's API link sends, plus the instance number (MAVSDK listens here)."""
MAX_DATAGRAM = 65535


@dataclasses.dataclass(frozen=True)
class Link:
    """One UDP link: bound to ``local_port`` (0: any) on ``host``, sending to ``remote_port``."""

    remote_port: int
    local_port: int = 0
    host: str = "127.0.0.1"


class UdpBridge:
    """A participant carrying the autopilot's MAVLink topics over UDP links."""

    def __init__(self, links: list[Link], uplink: str, downlink: str, period: float) -> None:
        self.period = period
        self.uplink = uplink
        self.downlink = downlink
        self._links = links
        self._socks: list[tuple[socket.socket, tuple[str, int]]] = []
        self._down: Subscription[MavlinkPacket] | None = None
        self.received = 0
        self.sent = 0
        try:
            for link in links:
                sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                sock.bind((link.host, link.local_port))
                sock.setblocking(False)
                self._socks.append((sock, (link.host, link.remote_port)))
        except BaseException:
            self.close()
            raise

    @property
    def local_ports(self) -> list[int]:
        """The bound local port of each link."""
        return [int(s.getsockname()[1]) for s, _ in self._socks]

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the autopilot's downlink."""
        self._down = ctx.subscribe(self.downlink, MavlinkPacket)

    def step(self, ctx: StepContext) -> None:
        """Forward datagrams received since the last step; send what the autopilot sent."""
        for i, (sock, _) in enumerate(self._socks):
            while True:
                try:
                    data, peer = sock.recvfrom(MAX_DATAGRAM)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:  # e.g. ICMP port unreachable reported on a later call
                    break
                # Answer whoever talks to us (PX4 does the same).
                self._socks[i] = (sock, peer)
                self.received += 1
                ctx.publish(self.uplink, MavlinkPacket(data))
        down = self._down
        if down is not None and down.fresh:
            for packet in down.messages:
                for sock, peer in self._socks:
                    with contextlib.suppress(OSError):
                        sock.sendto(packet.data, peer)
                        self.sent += 1

    def close(self) -> None:
        """Close the sockets."""
        for sock, _ in self._socks:
            sock.close()
        self._socks = []
