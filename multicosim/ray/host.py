"""The Ray actor that runs one component's program on its node, and answers for it.

[`ComponentHost`][multicosim.ray.host.ComponentHost] is what the ``ray`` placement creates for each
participant and firmware: on the node Ray chose, it starts the component's program (``python -m
multicosim participant ...`` or ``... serve ...``) as a local process there, with the environment
the driver gives it, and then answers the driver's questions (has it exited? its output?) until
it is told to stop it. Nothing here imports Ray: the class becomes an actor where it is used.

The program is killed with its actor (SIGKILL once the actor's process has gone, on Linux),
and its output is kept in an anonymous file that disappears with them: a killed actor leaves
neither a process nor a file behind.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

__all__ = ["HOST_PLACEHOLDER", "ComponentHost", "Placed"]

HOST_PLACEHOLDER = "{host}"
"""Replaced, in a program's arguments, by the address of the node it runs on."""

_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


class Placed(NamedTuple):
    """Where a program was started: its process id there, its node and the actor's process."""

    pid: int
    node_id: str
    node_ip: str
    worker_pid: int


def _die_with_actor() -> Callable[[], None] | None:
    """What the program's process runs before its program: die when the actor dies (Linux).

    Linux signals the child when the *thread* that started it ends; an actor of one
    concurrency runs its methods on its process's main thread, which lives as long as it.
    """
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    parent = os.getpid()

    def arm() -> None:  # between fork and exec: no imports, no locks
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        if os.getppid() != parent:
            os._exit(1)  # the actor died before the signal was armed
        # Ray's worker may ignore these, and an ignored signal stays ignored across exec.
        with contextlib.suppress(ValueError):  # only where the actor runs on its main thread
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)

    return arm


def _node() -> tuple[str, str]:
    import ray

    address: str = ray.util.get_node_ip_address()  # type: ignore[no-untyped-call]
    return ray.get_runtime_context().get_node_id(), address


class ComponentHost:
    """Runs component ``name``'s program on this node; reports on it; stops it."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._process: subprocess.Popen[bytes] | None = None
        # No name in the file system: nothing to remove, whatever ends the actor.
        self._log = tempfile.TemporaryFile()  # noqa: SIM115 - closed in terminate()

    def start(self, args: Sequence[str], env: Mapping[str, str], path: Sequence[str]) -> Placed:
        """Start ``python -m ARGS`` (``{host}`` in them: this node's address) with ``env``
        added to this worker's environment and ``path`` (those entries that exist here)
        first on its ``PYTHONPATH``."""
        if self._process is not None:
            raise RuntimeError(f"{self.name} was started already")
        node_id, node_ip = _node()
        command = [sys.executable, "-m", *(a.replace(HOST_PLACEHOLDER, node_ip) for a in args)]
        entries = [p for p in path if os.path.isdir(p)]
        if os.environ.get("PYTHONPATH"):
            entries.append(os.environ["PYTHONPATH"])
        self._process = subprocess.Popen(
            command,
            stdin=subprocess.DEVNULL,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env={**os.environ, **env, "PYTHONPATH": os.pathsep.join(entries)},
            start_new_session=True,
            preexec_fn=_die_with_actor(),
        )
        return Placed(self._process.pid, node_id, node_ip, os.getpid())

    def poll(self) -> int | None:
        """The program's exit code once it has exited, else None."""
        return None if self._process is None else self._process.poll()

    def frozen(self) -> bool:
        """Whether the program is stopped (SIGSTOP, a debugger)."""
        process = self._process
        if process is None or process.poll() is not None:
            return False
        try:
            with open(f"/proc/{process.pid}/stat") as f:
                state = f.read().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            return False
        return state in ("T", "t")

    def read_log(self, last: int | None = None) -> bytes:
        """The program's output so far (its ``last`` bytes)."""
        if self._log.closed:
            return b""
        fd = self._log.fileno()
        size = os.fstat(fd).st_size
        start = 0 if last is None else max(0, size - last)
        return os.pread(fd, size - start, start)

    def terminate(self, timeout: float) -> int | None:
        """TERM the program's process group, wait ``timeout`` s, then KILL it; its exit code
        (None if it was never started)."""
        process = self._process
        if process is None:
            return None
        if process.poll() is None:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(process.pid, signal.SIGTERM)
                # A stopped (frozen) program acts on SIGTERM only once it continues.
                os.killpg(process.pid, signal.SIGCONT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                process.wait(timeout)
        # Children may outlive the leader: KILL whatever is left of the group.
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)
        return process.wait()
