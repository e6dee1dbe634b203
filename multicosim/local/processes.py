"""Components run as local processes: commands, process handles and nodes, the start handshake."""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import functools
import logging
import os
import resource
import shlex
import signal
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Literal

from ..core import wire
from ..core.errors import ConfigurationError, NodeCrashedError, NodeStartError
from .environment import LocalEnvironment
from .rundirs import process_state
from .waits import (
    DEFAULT_START_TIMEOUT,
    Problem,
    check_timeout,
    ending,
    memory_bytes,
    memory_text,
    reported,
)

__all__ = [
    "ProcessComponent",
    "ProcessHandle",
    "ProcessNode",
    "before_exec",
    "check_memory",
    "check_port",
    "default_name",
    "split_command",
    "start_process",
]

log = logging.getLogger(__name__)


def split_command(command: str | Sequence[str], field: str = "command") -> list[str]:
    """A command line as a list of arguments; ConfigurationError naming ``field`` if empty."""
    args = shlex.split(command) if isinstance(command, str) else [str(a) for a in command]
    if not args or not args[0].strip():
        raise ConfigurationError(field, command, "a non-empty command")
    return args


def default_name(args: list[str]) -> str:
    """A component name from its command: the target of ``python -m multicosim serve M:F``
    (``f``), the module of ``python -m M``, the script's stem, or the program's name."""
    for i, arg in enumerate(args):
        if arg in ("serve", "participant") and i + 1 < len(args) and ":" in args[i + 1]:
            return args[i + 1].rsplit(":", 1)[1].rsplit(".", 1)[-1].lower()
    program = Path(args[0]).name
    if program.startswith("python") and len(args) > 1:
        if args[1] == "-m" and len(args) > 2:
            return args[2].rsplit(".", 1)[-1]
        if not args[1].startswith("-"):
            return Path(args[1]).stem
    return program


def check_port(port: int | None) -> None:
    """Raise ConfigurationError unless ``port`` is None or a port number 1..65535."""
    if port is not None and (
        isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535
    ):
        raise ConfigurationError("port", port, "an integer port in 1..65535, or None for any")


def _resolve_python(args: list[str]) -> list[str]:
    # "python" in a component command means the interpreter running the simulation, so a
    # virtual environment's packages are seen by its components.
    if args[0] in ("python", "python3"):
        return [sys.executable, *args[1:]]
    return args


def _python_path(given: str | None) -> str:
    """``PYTHONPATH`` for a component: ``given`` first, then this process's own import path.

    A component imports the user's modules as the code that started it did (a test's
    rootdir, which pytest put on ``sys.path``; a script's directory), wherever the run was
    started from. The interpreter's own entries (the standard library, site-packages) are
    left out: the component's interpreter has its own.
    """
    prefixes = {
        Path(p).resolve()
        for p in (sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix)
    }
    entries = [given] if given else []
    for entry in sys.path:
        path = Path(entry or os.getcwd()).resolve()
        if any(path.is_relative_to(prefix) for prefix in prefixes) or not path.exists():
            continue
        if str(path) not in entries:
            entries.append(str(path))
    return os.pathsep.join(entries)


_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>

MIN_MEMORY = 16 << 20
"""The smallest memory cap a process component takes (a Python interpreter needs more)."""


@functools.cache
def _prctl() -> Callable[..., int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl: Callable[..., int] = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    return prctl


def before_exec(memory: int | None) -> Callable[[], None] | None:
    """What a child runs before its program: die with its host; cap its memory.

    Even a component busy inside a step then ends with its host (SIGKILL to pytest, a crash,
    an out-of-memory kill), instead of waiting for the next session's sweep: on Linux it
    gets SIGKILL once its host has died. Linux delivers the signal when the *thread* that
    started the child ends, so simulations must run in a thread that outlives them
    (pytest's, a script's main thread). Elsewhere components only notice a lost host while
    they wait (``multicosim.runtime.HostWatch``). ``memory`` caps its address space
    (``RLIMIT_AS``): an allocation past it fails (Python raises MemoryError).
    """
    prctl = _prctl()
    if prctl is None and memory is None:
        return None
    host = os.getpid()

    def arm() -> None:  # runs in the child between fork and exec: no imports, no locks
        if prctl is not None:
            prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
            if os.getppid() != host:
                os._exit(1)  # the host died before the signal was armed
        if memory is not None:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    return arm


class ProcessHandle:
    """A started local process in its own process group, with its output in a log file.

    It is killed (SIGKILL) if its host process dies, even in the middle of a step (Linux).
    ``memory`` (bytes) caps its address space. Its output stays readable while it runs even
    if its log file is removed (read through the handle's own descriptor).
    """

    def __init__(
        self,
        name: str,
        args: list[str],
        *,
        env: Mapping[str, str],
        cwd: str | None,
        log_path: Path,
        memory: int | None = None,
    ) -> None:
        self.name = name
        self.args = args
        self.log_path = log_path
        self.memory = memory
        # Read and append: the tail is read through this descriptor, which outlives the
        # file's name (a run directory removed under a running simulation).
        self._log = open(log_path, "a+b")  # noqa: SIM115 - closed in terminate()
        try:
            self.popen = subprocess.Popen(
                args,
                stdin=subprocess.DEVNULL,
                stdout=self._log,
                stderr=subprocess.STDOUT,
                env={**os.environ, **env},
                cwd=cwd,
                start_new_session=True,
                preexec_fn=before_exec(memory),
            )
        except OSError as exc:
            self._log.close()
            raise NodeStartError(name, f"could not be started: {exc}") from exc
        self.pid = self.popen.pid
        self.stopping = False

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        return self.popen.poll()

    def log_tail(self, lines: int = 40) -> str:
        """The last ``lines`` lines of its output."""
        return "\n".join(self.read_log(16384).decode(errors="replace").splitlines()[-lines:])

    def read_log(self, last: int | None = None) -> bytes:
        """Its output so far (the ``last`` bytes of it); empty if it cannot be read."""
        try:
            if not self._log.closed:
                fd = self._log.fileno()
                size = os.fstat(fd).st_size
                start = 0 if last is None else max(0, size - last)
                return os.pread(fd, size - start, start)
            with open(self.log_path, "rb") as f:
                if last is not None:
                    f.seek(0, os.SEEK_END)
                    f.seek(max(0, f.tell() - last))
                return f.read()
        except OSError:
            return b""

    def restore_log(self) -> None:
        """Write its log file again if it was removed while the process ran (from the open
        file: what was written before, and since, is all there)."""
        if self._log.closed or self.log_path.exists():
            return
        output = self.read_log()
        self.log_path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        self.log_path.write_bytes(output)

    def diagnose(self) -> Problem | None:
        """Frozen if it is stopped (SIGSTOP, a debugger); see ``multicosim.local.waits``."""
        if self.popen.poll() is None and process_state(self.pid) in ("T", "t"):
            return Problem("frozen", "its process is stopped, as by SIGSTOP")
        return None

    def terminate(self, timeout: float) -> int:
        """TERM the process group, wait ``timeout``, then KILL; return the exit code."""
        self.stopping = True
        try:
            if self.popen.poll() is None:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(self.pid, signal.SIGTERM)
                    # A stopped (frozen) process acts on SIGTERM only once it continues.
                    os.killpg(self.pid, signal.SIGCONT)
                try:
                    self.popen.wait(timeout)
                except subprocess.TimeoutExpired:
                    log.warning("%s ignored SIGTERM for %g s; killing it", self.name, timeout)
            # Children may outlive the leader: KILL whatever is left of the group.
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.pid, signal.SIGKILL)
            return self.popen.wait()
        finally:
            self._log.close()


class ProcessNode:
    """A component running as a local process."""

    def __init__(
        self,
        handle: ProcessHandle,
        stop_timeout: float,
        environment: LocalEnvironment,
        cwd: str | None = None,
    ) -> None:
        self.handle = handle
        self.name = handle.name
        self.cwd = Path(cwd) if cwd is not None else None
        """Its working directory (None: the one it was started from)."""
        self._stop_timeout = stop_timeout
        self._environment = environment
        self._stopped = False

    @property
    def pid(self) -> int:
        """The process id (also its process group id)."""
        return self.handle.pid

    @property
    def log_path(self) -> Path:
        """The file holding its stdout and stderr."""
        return self.handle.log_path

    def files(self, path: str, suffix: str, into: Path) -> list[Path]:
        """Its files ending in ``suffix`` under ``path`` of its working directory (they are
        on this machine already: ``into`` is not used)."""
        root = (self.cwd or Path.cwd()) / path
        return sorted(root.glob(f"**/*{suffix}"))

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        return self.handle.poll()

    def log_tail(self, lines: int = 40) -> str:
        """The last lines of its output."""
        return self.handle.log_tail(lines)

    def diagnose(self) -> Problem | None:
        """What is known to be wrong with it (see ``ProcessHandle.diagnose``)."""
        return self.handle.diagnose()

    @property
    def memory(self) -> int | None:
        """Its memory cap in bytes, if it has one."""
        return self.handle.memory

    def stop(self) -> None:
        """Terminate it; raise NodeCrashedError if it had failed before it was stopped."""
        if self._stopped:
            return
        self._stopped = True
        if self._environment.has_coordinator:
            self._environment.coordinator.forget(self.name)
        early = self.handle.poll()
        self.handle.terminate(self._stop_timeout)
        if early is not None and early != 0 and self.handle not in reported:
            raise NodeCrashedError(
                self.name,
                f"{ending(self.handle)} before it was stopped",
                exit_code=early,
                log_tail=self.handle.log_tail(),
            )


def check_memory(memory: object) -> None:
    """Raise ConfigurationError unless ``memory`` is None or a size of at least 16 MiB."""
    if memory is not None and memory_bytes(memory, MIN_MEMORY) is None:
        raise ConfigurationError(
            "memory",
            memory,
            f"None, or bytes (an integer >= {memory_text(MIN_MEMORY)}) or a size like '512m', '2g'",
        )


def _log_path(environment: LocalEnvironment, name: str) -> Path:
    return environment.run_dir / f"{name}.log"


def start_process(
    environment: LocalEnvironment,
    name: str,
    args: list[str],
    *,
    env: Mapping[str, str],
    cwd: str | None,
    handshake: bool,
    start_timeout: float,
    stop_timeout: float,
    memory: int | str | None = None,
) -> tuple[ProcessNode, wire.Hello | None]:
    """Start component ``name`` as a process (``memory``: its cap, see ``check_memory``);
    with ``handshake``, wait until it has joined the simulation."""
    order = environment.next_order()
    handle = ProcessHandle(
        name,
        _resolve_python(args),
        env={
            **environment.component_env(name),
            **env,
            "PYTHONPATH": _python_path(env.get("PYTHONPATH", os.environ.get("PYTHONPATH"))),
        },
        cwd=cwd,
        log_path=_log_path(environment, name),
        memory=None if memory is None else memory_bytes(memory),
    )
    environment.processes[name] = handle
    environment.record_pid(handle.pid)
    node = ProcessNode(handle, stop_timeout, environment, cwd)
    environment.coordinator.expect(name, order, handle)
    hello = None
    try:
        if handshake:
            hello = environment.coordinator.wait_ready(name, start_timeout)
    except BaseException:
        handle.terminate(stop_timeout)
        raise
    return node, hello


@dataclasses.dataclass(frozen=True)
class ProcessComponent:
    """A component run as a local process (the local counterpart of ContainerComponent).

    ``ready="handshake"`` (default) waits for the program to join the simulation (programs
    built with multicosim do so); ``ready="started"`` is for arbitrary commands. ``memory``
    caps its address space (``RLIMIT_AS``; bytes, or ``"512m"``, ``"2g"``; None: no cap):
    past it an allocation fails, and the error says it ran out of memory.

    A Python program imports modules as the code that started the simulation does: the
    directories on its ``sys.path`` (a test's rootdir, a script's directory) are on the
    process's ``PYTHONPATH``, after any ``PYTHONPATH`` in ``env``, wherever pytest or the
    script was started from.
    """

    command: str | Sequence[str]
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    cwd: str | None = None
    ready: Literal["handshake", "started"] = "handshake"
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = 5.0
    memory: int | str | None = None

    def __post_init__(self) -> None:
        args = split_command(self.command)
        if self.ready not in ("handshake", "started"):
            raise ConfigurationError("ready", self.ready, "'handshake' or 'started'")
        check_memory(self.memory)
        check_timeout("start_timeout", self.start_timeout)
        check_timeout("stop_timeout", self.stop_timeout)
        if self.name is None:
            object.__setattr__(self, "name", default_name(args))

    def start(self, environment: LocalEnvironment) -> ProcessNode:
        """Start the process; with a handshake, return once it has joined the simulation."""
        assert self.name is not None
        node, _ = start_process(
            environment,
            self.name,
            split_command(self.command),
            env=self.env,
            cwd=self.cwd,
            handshake=self.ready == "handshake",
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
            memory=self.memory,
        )
        return node
