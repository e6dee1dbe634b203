"""LocalCluster: a Ray cluster of several nodes on this machine, for tests and benchmarks.

Each node is its own ``ray start --block`` process (a head, then workers joining it), in a
session of its own, with the cluster's files in a private temporary directory and every
port chosen free, so that clusters of parallel runs do not meet. Stopping TERMs each node
(workers first), waits, then KILLs what is left of its process group and removes the
directory; a node also dies with the process that started it (Linux).
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Self

from ..core.errors import ConfigurationError, PlacementUnavailableError

__all__ = ["LocalCluster"]

log = logging.getLogger(__name__)

_READY = "Ray runtime started."  # what `ray start` prints once its node runs
_PR_SET_PDEATHSIG = 1


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
    return port


def _die_with_parent() -> Callable[[], None] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    parent = os.getpid()

    def arm() -> None:  # between fork and exec
        # SIGTERM: `ray start --block` then stops its node's processes before it exits.
        prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
        if os.getppid() != parent:
            os._exit(1)

    return arm


class LocalCluster:
    """``nodes`` Ray nodes on this machine (a head and ``nodes - 1`` workers) of ``num_cpus``
    CPUs each; ``address`` is the head's, for ``Ray(address)`` or ``MCS_RAY_ADDRESS``.

    A context manager: ``start`` returns once every node runs (within ``start_timeout``
    seconds, else PlacementUnavailableError with the node's output), ``stop`` is
    idempotent. The nodes authenticate as this process's ``RAY_AUTH_MODE`` says (unset:
    no authentication, as a driver joining by address expects).
    """

    def __init__(self, nodes: int = 2, *, num_cpus: int = 1, start_timeout: float = 60.0) -> None:
        for field, value, least in (("nodes", nodes, 1), ("num_cpus", num_cpus, 0)):
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ConfigurationError(field, value, f"an integer >= {least}")
        self.nodes = nodes
        self.num_cpus = num_cpus
        self.start_timeout = start_timeout
        self.address = ""
        self.temp_dir: Path | None = None
        self._processes: list[tuple[str, subprocess.Popen[bytes], Path]] = []

    def start(self) -> Self:
        """Start the head, then the workers; return once every node runs."""
        if self.temp_dir is not None:
            raise RuntimeError("this cluster was started already")
        # Short: Ray's Unix sockets live under it, and their paths are limited in length.
        self.temp_dir = Path(tempfile.mkdtemp(prefix="mcs-ray-"))
        port = _free_port()
        self.address = f"127.0.0.1:{port}"
        common = [
            "--block",
            f"--num-cpus={self.num_cpus}",
            "--disable-usage-stats",
            "--min-worker-port=0",
            "--max-worker-port=0",
            "--dashboard-agent-listen-port=0",
        ]
        try:
            self._node(
                "head",
                "--head",
                f"--port={port}",
                f"--temp-dir={self.temp_dir}",
                "--include-dashboard=false",
                f"--dashboard-port={_free_port()}",
                *common,
            )
            for i in range(1, self.nodes):
                self._node(f"worker-{i}", f"--address={self.address}", *common)
            deadline = time.monotonic() + self.start_timeout
            for name, process, output in self._processes:
                _wait_ready(name, process, output, deadline)
        except BaseException:
            self.stop()
            raise
        log.info("a local Ray cluster of %d nodes runs at %s", self.nodes, self.address)
        return self

    def _node(self, name: str, *args: str) -> None:
        assert self.temp_dir is not None
        output = self.temp_dir / f"{name}.out"
        env = {**os.environ, "RAY_AUTH_MODE": os.environ.get("RAY_AUTH_MODE", "disabled")}
        env.pop("RAY_ADDRESS", None)
        with open(output, "wb") as out:
            process = subprocess.Popen(
                [sys.executable, "-m", "ray.scripts.scripts", "start", *args],
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
                preexec_fn=_die_with_parent(),
            )
        self._processes.append((name, process, output))

    def stop(self) -> None:
        """Stop every node (workers first) and remove the cluster's files; idempotent."""
        processes, self._processes = self._processes, []
        for _, process, _ in reversed(processes):
            _stop_group(process)
        if self.temp_dir is not None:
            shutil.rmtree(self.temp_dir, ignore_errors=True)

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.stop()


def _wait_ready(name: str, process: subprocess.Popen[bytes], output: Path, deadline: float) -> None:
    while _READY not in output.read_text(errors="replace"):
        if process.poll() is not None or time.monotonic() > deadline:
            tail = "\n".join(output.read_text(errors="replace").splitlines()[-20:])
            why = "exited" if process.poll() is not None else "did not start in time"
            raise PlacementUnavailableError(f"the local Ray node {name} {why}", tail)
        time.sleep(0.1)


def _stop_group(process: subprocess.Popen[bytes], timeout: float = 30.0) -> None:
    """TERM the node's `ray start` (it stops its node), wait, then KILL the rest of its group."""
    with contextlib.suppress(ProcessLookupError):
        process.terminate()
    try:
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        log.warning("a local Ray node ignored SIGTERM for %g s; killing it", timeout)
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    # Its processes may outlive it for a moment; orphans are reaped by init (bounded).
    deadline = time.monotonic() + timeout
    while True:
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            return
        if time.monotonic() > deadline:
            log.warning("processes of a local Ray node are left in group %d", process.pid)
            return
        time.sleep(0.05)
