"""Launching real SITL firmware (PX4, ArduPilot) beside a simulation: the parts both share.

Used by :mod:`multicosim.px4.sitl` and :mod:`multicosim.ardupilot.launch`:

* :class:`SitlNodes`: the firmware's process or container and its bridges, stopped as one,
  in reverse start order (a half-started launch is stopped before its error propagates);
* :func:`run_container`: the firmware as a container on the simulation's network;
* :func:`copy_out`: flight logs out of a container; :func:`udp_free`,
  :func:`check_first_instance`, :func:`param_value`: instance claims and parameter files.
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
