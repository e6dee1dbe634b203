"""Real PX4 SITL as the firmware of the PX4 scenario: the top of the fidelity ladder.

PX4's SITL build (``px4_sitl_default``) flies our MuJoCo quadrotor the way it flies Gazebo's:
its ``simulator_mavlink`` module connects to :class:`~._hilserver.HilTcpBridge` (TCP
4560 + instance, lockstep), and its MAVLink API link is carried to the same ground station
that drives our built-in autopilot (:mod:`._gcs`), so ``simulation.firmware.send`` flies a
mission on either.

Where PX4 comes from is a :class:`SITL`: a ``px4`` binary with its ``etc`` ROMFS beside it
(``../shared/px4-sitl`` or a ``build/px4_sitl_default`` tree) run as a local process, or an
image (``multicosim images build --px4-dir DIR``) run as a container on the simulation's
network. Each PX4 gets:

* its own instance number (claimed by binding its simulator port; the other ports checked
  free), so parallel runs (``pytest -n 2``) never share ports, lock files or sockets;
* a fresh working directory in the run directory (PX4 keeps parameters there);
* a private ``bin`` directory first on its PATH with the ``px4-<module>`` command links its
  start-up script calls (so a bundle whose links were flattened into files still runs), and
  the ``px4-rc.params`` / ``px4-rc.mavlink`` hooks that PX4's start-up script sources from
  the PATH: our parameters, and one MAVLink link to our ground station instead of PX4's
  defaults (nothing is sent to other programs' ports).
"""

from __future__ import annotations

import contextlib
import logging
import socket
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError
from ..core.interfaces import Node

if TYPE_CHECKING:
    pass

log = logging.getLogger(__name__)


def udp_free(host: str, port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


def check_first_instance(first: object, most: int) -> None:
    """Raise ConfigurationError unless ``first`` is an instance number from 0 to ``most``."""
    if isinstance(first, bool) or not isinstance(first, int) or not 0 <= first <= most:
        raise ConfigurationError("first_instance", first, f"an instance number from 0 to {most}")


def param_value(value: float) -> str:
    return str(int(value)) if float(value).is_integer() and abs(value) < 2**31 else repr(value)


class SitlNodes:
    """PX4's process or container with its bridges: stopped as one, in reverse start order."""

    def __init__(self, name: str, container_logs: str = "") -> None:
        self.name = name
        self.container_logs = container_logs
        self.nodes: list[tuple[str, Node]] = []
        self.process: Any = None
        self.rootfs: Path | None = None
        self.instance = 0

    def add(self, name: str, node: Node) -> None:
        """Track ``node`` (stopped before those added earlier)."""
        self.nodes.append((name, node))

    @contextlib.contextmanager
    def starting(self) -> Iterator[SitlNodes]:
        """Stop every part started so far if the start fails; the start's error propagates."""
        try:
            yield self
        except BaseException as exc:
            try:
                self.stop()
            except Exception as cleanup:  # the start error says what matters; keep this too
                exc.add_note(f"while stopping what had started: {cleanup!r}")
            raise

    def flight_logs(self, into: Path) -> list[Path]:
        """The firmware's ULog files (``log/**/*.ulg`` in its working directory, or under
        ``container_logs`` in its container, copied into ``into``)."""
        container = getattr(self.process, "container", None)
        if container is not None:
            return copy_out(container, self.container_logs, into) if self.container_logs else []
        if self.rootfs is None:
            return []
        return sorted((self.rootfs / "log").glob("**/*.ulg"))

    def stop(self) -> None:
        """Stop every node; raise what failed, together."""
        from ..local.simulation import stop_all

        nodes, self.nodes = self.nodes, []
        stop_all([(name, node.stop) for name, node in reversed(nodes)], f"component {self.name!r}")


def copy_out(container: Any, path: str, into: Path, suffix: str = ".ulg") -> list[Path]:
    """The ``suffix`` files under ``path`` in ``container``, copied into ``into``."""
    import io
    import tarfile

    try:
        stream, _ = container.get_archive(path)
    except Exception:  # no log directory yet, or the container is gone
        return []
    data = io.BytesIO(b"".join(stream))
    into.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=data) as tar:
        members = [m for m in tar.getmembers() if m.isfile() and m.name.endswith(suffix)]
        tar.extractall(into, members=members, filter="data")
    return sorted(into.glob(f"**/*{suffix}"))


def is_container_environment(environment: Any) -> bool:
    # Without the docker backend loaded there is no container environment (and no SDK).
    docker = sys.modules.get("multicosim.docker.environment")
    return docker is not None and isinstance(environment, docker.ContainerEnvironment)


def run_container(environment: Any, image: str, command: list[str], name: str) -> Node:
    """Start firmware ``command`` in a container of ``image`` on the simulation's network."""
    from ..docker import ContainerComponent

    node: Node = ContainerComponent(
        image, command, name=name, ready="started", stop_timeout=10.0
    ).start(environment)
    return node
