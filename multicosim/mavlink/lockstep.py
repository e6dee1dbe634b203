"""Lockstep bridges to firmware over sockets: the first client that speaks MAVLink, and what
a bridge needs to tell a firmware that went away or went silent.

Every simulator bridge of a real firmware uses them: PX4's simulator interface
(``multicosim.px4.simulator``) and ArduPilot's JSON physics
([`multicosim.ardupilot`][multicosim.ardupilot]). A connection that does not speak MAVLink is
closed, so a stray local client cannot take the firmware's place.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import time
from collections.abc import Callable
from typing import Any, NamedTuple

from ..core.errors import MulticosimError, NodeCrashedError, NodeTimeoutError
from ..local import Watch, crashed, stalled
from .dialect import new_link

__all__ = ["RECV", "FirstMavlinkClient", "Lockstep", "MavlinkClient", "parse"]

log = logging.getLogger(__name__)

RECV = 65536  # bytes read from a socket at a time
_MAX_PREAMBLE = 600  # bytes a client may send before its first MAVLink frame (2 frames' worth)


def parse(parser: Any, data: bytes) -> list[Any]:
    """The MAVLink messages in ``data`` (garbage, which pymavlink reports as BAD_DATA, left out)."""
    try:
        frames = parser.parse_buffer(data) or ()
    except Exception:  # pymavlink raises its own errors on garbage it cannot skip
        return []
    return [m for m in frames if m.get_type() != "BAD_DATA"]


class MavlinkClient(NamedTuple):
    """A client taken by ``FirstMavlinkClient``."""

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
            frames = parse(parser, data) if data else []
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
