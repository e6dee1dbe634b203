"""Local execution: components in-process or as local processes, in lockstep.

``ProcessSimulator`` is the embedded default backend (no Docker needed). Its environment
(:class:`LocalEnvironment`) holds the simulated clock and, once a process needs it, the
coordinator socket through which process components are stepped.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
import weakref
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Generic, Literal, Protocol, Self, TypeVar, overload

import msgspec
import zmq

from . import _wire as wire
from ._clock import Delivery, Member, Scheduler, StepResult
from ._errors import (
    ConfigurationError,
    MessageTypeError,
    MulticosimError,
    NodeCrashedError,
    NodeError,
    NodeStartError,
    NodeTimeoutError,
    RemoteError,
    SimulationStopped,
    TransportError,
)
from ._interfaces import Component, Node, NodeId, new_simulator_token
from ._messages import decode, encode, type_name
from ._runtime import (
    Firmware,
    FirmwareContext,
    LocalDriver,
    LocalParticipantLink,
    Participant,
    StepContext,
    derive_seed,
)
from ._simulation import NodeSet

__all__ = [
    "FirmwareNode",
    "FirmwareProcessComponent",
    "FirmwareThreadComponent",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "InProcessSimulation",
    "InProcessSimulator",
    "LocalEnvironment",
    "ParticipantComponent",
    "ParticipantNode",
    "ProcessComponent",
    "ProcessNode",
    "ProcessSimulation",
    "ProcessSimulator",
    "ScenarioSimulation",
    "runs_directory",
    "sweep_stale_runs",
]

log = logging.getLogger(__name__)

MsgT = TypeVar("MsgT")
ReplyT = TypeVar("ReplyT")
NodeT = TypeVar("NodeT", bound=Node)

_SLICE_MS = 100  # how often a wait checks liveness and deadlines
DEFAULT_SEND_TIMEOUT = 120.0
DEFAULT_START_TIMEOUT = 30.0
DEFAULT_STEP_TIMEOUT = 60.0


class Watch(Protocol):
    """Something whose liveness a wait can check: a process or a container."""

    name: str

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        ...

    def log_tail(self, lines: int = 40) -> str:
        """The last lines of its output."""
        ...


# Watches whose crash has already been raised to the caller, so that stopping them later
# does not report the same crash a second time.
_reported: weakref.WeakSet[Any] = weakref.WeakSet()


def crashed(watch: Watch, reason: str) -> NodeCrashedError:
    """A NodeCrashedError for ``watch`` (exit code, log tail), remembered as reported."""
    mark_reported(watch)
    return NodeCrashedError(watch.name, reason, exit_code=watch.poll(), log_tail=watch.log_tail())


def mark_reported(watch: object) -> None:
    """Remember that ``watch``'s exit was raised already (stopping it will not raise it again)."""
    _reported.add(getattr(watch, "handle", watch))


# -- run directories and the sweep ----------------------------------------------------------


def runs_directory() -> Path:
    """Where run directories live unless a simulator is given one (per user)."""
    return Path(tempfile.gettempdir()) / f"multicosim-{os.getuid()}" / "runs"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _process_run_id(pid: int) -> str | None:
    try:
        environ = Path(f"/proc/{pid}/environ").read_bytes()
    except OSError:
        return None
    for entry in environ.split(b"\0"):
        if entry.startswith(wire.ENV_RUN_ID.encode() + b"="):
            return entry.split(b"=", 1)[1].decode()
    return None


def sweep_stale_runs(base: Path | None = None) -> list[int]:
    """Kill the process groups left by runs whose host process has died; return their pids.

    Each run records its host pid and every process it started; a process is killed only if
    it still carries that run's id in its environment (so a recycled pid is never hit).
    """
    base = base or runs_directory()
    killed: list[int] = []
    if not base.is_dir():
        return killed
    for run_dir in base.iterdir():
        owner_file = run_dir / "owner"
        try:
            owner = int(owner_file.read_text())
        except (OSError, ValueError):
            continue
        if _pid_alive(owner):
            continue
        try:
            lines = (run_dir / "pids").read_text().split()
        except OSError:
            lines = []
        for text in lines:
            pid = int(text)
            if _process_run_id(pid) == run_dir.name:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(pid, signal.SIGKILL)
                killed.append(pid)
        _remove_tree(run_dir)
    return killed


def _remove_tree(path: Path) -> None:
    import shutil

    shutil.rmtree(path, ignore_errors=True)


# -- the environment, the coordinator -------------------------------------------------------


class Coordinator:
    """The host end of the lockstep protocol: a ROUTER socket participants connect to."""

    def __init__(self, scheduler: Scheduler, zctx: zmq.Context[Any], host: str) -> None:
        self.scheduler = scheduler
        self.socket = zctx.socket(zmq.ROUTER)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.setsockopt(zmq.ROUTER_MANDATORY, 1)
        port = self.socket.bind_to_random_port(f"tcp://{host}")
        self.address = f"tcp://{host}:{port}"
        self.step_timeout = DEFAULT_STEP_TIMEOUT
        self._expected: dict[str, tuple[int, Watch | None]] = {}
        # Socket.poll builds a Poller per call; the lockstep exchange waits once per step.
        self._solo = zmq.Poller()
        self._solo.register(self.socket, zmq.POLLIN)
        self._pollers: dict[zmq.Socket[Any] | None, zmq.Poller] = {None: self._solo}
        self._hellos: dict[str, wire.Hello] = {}
        self._watches: dict[str, Watch] = {}

    def expect(self, name: str, order: int, watch: Watch | None) -> None:
        """Announce participant ``name`` (its place in the step order, how to watch it)."""
        self._expected[name] = (order, watch)
        if watch is not None:
            self._watches[name] = watch

    def wait_ready(self, name: str, timeout: float) -> wire.Hello:
        """Wait for ``name``'s hello; raise NodeStartError if it exits or times out first."""
        deadline = time.monotonic() + timeout
        watch = self._expected[name][1]
        while name not in self._hellos:
            self.pump(_SLICE_MS, None)
            if name in self._hellos:
                break
            if watch is not None and (code := watch.poll()) is not None:
                raise NodeStartError(
                    name, "exited before it was ready", exit_code=code, log_tail=watch.log_tail()
                )
            if time.monotonic() > deadline:
                raise NodeStartError(
                    name,
                    f"did not become ready within {timeout:g} s (no handshake)",
                    log_tail=watch.log_tail() if watch else "",
                )
        return self._hellos[name]

    def pump(self, timeout_ms: int, extra: zmq.Socket[Any] | None = None) -> bool | None:
        """Handle incoming frames for up to ``timeout_ms``.

        Returns True if ``extra`` became readable, False if only coordinator frames came,
        None if nothing came at all (the moment for slower liveness checks).
        """
        poller = self._pollers.get(extra)
        if poller is None:
            # One poller per waiting socket: building one per wait costs a tenth of a
            # round trip.
            poller = self._pollers[extra] = zmq.Poller()
            poller.register(self.socket, zmq.POLLIN)
            if extra is not None:
                poller.register(extra, zmq.POLLIN)
        events = poller.poll(timeout_ms)
        if not events:
            return None
        ready = False
        for sock, _ in events:
            if sock is self.socket:
                self.drain()
            else:
                ready = True
        return ready

    def drain(self) -> None:
        """Handle every frame already queued on the coordinator socket."""
        while True:
            try:
                ident, raw = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            self._handle(ident.decode(), raw)

    def _handle(self, name: str, raw: bytes) -> wire.Yield | None:
        frame: wire.Hello | wire.Activate | wire.Yield = wire.to_coordinator.decode(raw)
        if isinstance(frame, wire.Hello):
            if name not in self._expected:
                log.warning("ignoring hello from unexpected participant %r", name)
                return None
            self._hellos[name] = frame
            order = self._expected[name][0]
            member = Member(
                name,
                order,
                _RemoteLink(self),
                drives=frame.drives,
                next_ns=None if frame.drives else self.scheduler.now_ns,
            )
            self.scheduler.add(member)
            self.scheduler.subscribe(member, frame.subscribe)
            return None
        if isinstance(frame, wire.Activate):
            self.scheduler.activate(self.scheduler.member(name), frame.subscribe)
            return None
        return frame

    def exchange(self, member: Member, time_ns: int, inbox: list[Delivery]) -> StepResult:
        """Step remote ``member``: send it its inbox, wait for its yield."""
        name = member.name
        step = wire.Step(time_ns, [(d.topic, d.time_ns, d.data) for d in inbox])
        try:
            self.socket.send_multipart([name.encode(), wire.encoder.encode(step)])
        except zmq.ZMQError as exc:
            watch = self._watches.get(name)
            if watch is None:
                raise TransportError(f"component {name!r} is unreachable") from exc
            raise crashed(watch, f"is unreachable at t={time_ns / 1e9:g} s") from exc
        deadline = time.monotonic() + self.step_timeout
        watch = self._watches.get(name)
        while True:
            if self._solo.poll(_SLICE_MS):
                ident, raw = self.socket.recv_multipart()
                sender = ident.decode()
                frame = self._handle(sender, raw)
                if frame is not None:
                    if sender != name:
                        raise TransportError(f"{sender!r} yielded while {name!r} had the turn")
                    outbox = [Delivery(t, time_ns, raw=d) for t, d in frame.outbox]
                    return StepResult(frame.next_ns, outbox, frame.subscribe)
                continue
            if watch is not None and watch.poll() is not None:
                raise crashed(watch, f"exited during its step at t={time_ns / 1e9:g} s")
            if time.monotonic() > deadline:
                raise NodeTimeoutError(
                    name,
                    f"did not finish its step at t={time_ns / 1e9:g} s within "
                    f"{self.step_timeout:g} s",
                    log_tail=watch.log_tail() if watch else "",
                )

    def check_alive(self) -> None:
        """Raise NodeCrashedError if any watched participant has exited."""
        for name, watch in self._watches.items():
            if name in self._hellos and watch.poll() is not None:
                raise crashed(watch, "exited while the simulation ran")

    def forget(self, name: str) -> None:
        """Stop watching ``name`` (it is being stopped on purpose)."""
        self._watches.pop(name, None)

    def close(self) -> None:
        """Close the socket."""
        self.socket.close(0)


class _RemoteLink:
    def __init__(self, coordinator: Coordinator) -> None:
        self.coordinator = coordinator

    def step(self, member: Member, time_ns: int, inbox: list[Delivery]) -> StepResult:
        return self.coordinator.exchange(member, time_ns, inbox)


class LocalEnvironment:
    """What a ProcessSimulator hands its components: clock, coordinator, seed, run directory."""

    def __init__(
        self,
        *,
        run_id: str,
        run_dir: Path,
        seed: int,
        scheduler: Scheduler,
        coordinator_host: str = "127.0.0.1",
    ) -> None:
        self.run_id = run_id
        self.run_dir = run_dir
        self.seed = seed
        self.scheduler = scheduler
        self.zctx: zmq.Context[Any] = zmq.Context()
        self._coordinator_host = coordinator_host
        self._coordinator: Coordinator | None = None
        self._order = 0

    @property
    def coordinator(self) -> Coordinator:
        """The coordinator socket, bound on first use."""
        if self._coordinator is None:
            self._coordinator = Coordinator(self.scheduler, self.zctx, self._coordinator_host)
        return self._coordinator

    @property
    def has_coordinator(self) -> bool:
        """Whether any process component has needed the coordinator."""
        return self._coordinator is not None

    def next_order(self) -> int:
        """The step-order slot of the next component (components step in start order)."""
        self._order += 1
        return self._order

    def component_env(self, name: str) -> dict[str, str]:
        """Environment variables that place a component process in this simulation."""
        return {
            wire.ENV_COORDINATOR: self.coordinator.address,
            wire.ENV_NODE_NAME: name,
            wire.ENV_SEED: str(self.seed),
            wire.ENV_RUN_ID: self.run_id,
        }

    def record_pid(self, pid: int) -> None:
        """Remember a started process group so a sweep can remove it if this run is killed."""
        with open(self.run_dir / "pids", "a") as f:
            f.write(f"{pid}\n")

    def idle(self, extra: zmq.Socket[Any]) -> bool | None:
        """Wait a slice for frames (see ``Coordinator.pump``); check participants when quiet."""
        if self._coordinator is None:
            return True if extra.poll(_SLICE_MS) else None
        ready = self._coordinator.pump(_SLICE_MS, extra)
        if ready is None:
            self._coordinator.check_alive()
        return ready

    def close(self) -> None:
        """Close sockets."""
        if self._coordinator is not None:
            self._coordinator.close()
        self.zctx.destroy(linger=0)


# -- processes ------------------------------------------------------------------------------


def _split_command(command: str | Sequence[str], field: str = "command") -> list[str]:
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


def _check_port(port: int | None) -> None:
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


class ProcessHandle:
    """A started local process in its own process group, with its output in a log file."""

    def __init__(
        self,
        name: str,
        args: list[str],
        *,
        env: Mapping[str, str],
        cwd: str | None,
        log_path: Path,
    ) -> None:
        self.name = name
        self.args = args
        self.log_path = log_path
        self._log = open(log_path, "ab")  # noqa: SIM115 - closed in terminate()
        try:
            self.popen = subprocess.Popen(
                args,
                stdin=subprocess.DEVNULL,
                stdout=self._log,
                stderr=subprocess.STDOUT,
                env={**os.environ, **env},
                cwd=cwd,
                start_new_session=True,
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
        try:
            with open(self.log_path, "rb") as f:
                f.seek(0, os.SEEK_END)
                f.seek(max(0, f.tell() - 16384))
                text = f.read().decode(errors="replace")
        except OSError:
            return ""
        return "\n".join(text.splitlines()[-lines:])

    def terminate(self, timeout: float) -> int:
        """TERM the process group, wait ``timeout``, then KILL; return the exit code."""
        self.stopping = True
        try:
            if self.popen.poll() is None:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(self.pid, signal.SIGTERM)
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
        self, handle: ProcessHandle, stop_timeout: float, environment: LocalEnvironment
    ) -> None:
        self.handle = handle
        self.name = handle.name
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

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        return self.handle.poll()

    def log_tail(self, lines: int = 40) -> str:
        """The last lines of its output."""
        return self.handle.log_tail(lines)

    def stop(self) -> None:
        """Terminate it; raise NodeCrashedError if it had failed before it was stopped."""
        if self._stopped:
            return
        self._stopped = True
        if self._environment.has_coordinator:
            self._environment.coordinator.forget(self.name)
        early = self.handle.poll()
        self.handle.terminate(self._stop_timeout)
        if early is not None and early != 0 and self.handle not in _reported:
            raise NodeCrashedError(
                self.name,
                "had exited before it was stopped",
                exit_code=early,
                log_tail=self.handle.log_tail(),
            )


def _log_path(environment: LocalEnvironment, name: str) -> Path:
    return environment.run_dir / f"{name}.log"


def _start_process(
    environment: LocalEnvironment,
    name: str,
    args: list[str],
    *,
    env: Mapping[str, str],
    cwd: str | None,
    handshake: bool,
    start_timeout: float,
    stop_timeout: float,
) -> tuple[ProcessNode, wire.Hello | None]:
    order = environment.next_order()
    handle = ProcessHandle(
        name,
        _resolve_python(args),
        env={**environment.component_env(name), **env},
        cwd=cwd,
        log_path=_log_path(environment, name),
    )
    environment.record_pid(handle.pid)
    node = ProcessNode(handle, stop_timeout, environment)
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
    built with multicosim do so); ``ready="started"`` is for arbitrary commands.
    """

    command: str | Sequence[str]
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    cwd: str | None = None
    ready: Literal["handshake", "started"] = "handshake"
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = 5.0

    def __post_init__(self) -> None:
        args = _split_command(self.command)
        if self.ready not in ("handshake", "started"):
            raise ConfigurationError("ready", self.ready, "'handshake' or 'started'")
        _check_positive("start_timeout", self.start_timeout)
        _check_positive("stop_timeout", self.stop_timeout)
        if self.name is None:
            object.__setattr__(self, "name", default_name(args))

    def start(self, environment: LocalEnvironment) -> ProcessNode:
        """Start the process; with a handshake, return once it has joined the simulation."""
        assert self.name is not None
        node, _ = _start_process(
            environment,
            self.name,
            _split_command(self.command),
            env=self.env,
            cwd=self.cwd,
            handshake=self.ready == "handshake",
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
        )
        return node


def _check_positive(field: str, value: float) -> None:
    if not isinstance(value, int | float) or not value > 0:
        raise ConfigurationError(field, value, "a positive number of seconds")


def _check_types(msgtype: object, replytype: object) -> None:
    if msgtype is not None and not isinstance(msgtype, type):
        raise ConfigurationError("msgtype", msgtype, "a message class or None")
    if replytype is not None and not isinstance(replytype, type):
        raise ConfigurationError("replytype", replytype, "a message class or None")


class FirmwareNode(Generic[MsgT, ReplyT]):
    """A CommunicationNode reached over ZeroMQ: a firmware in a process or a container.

    ``send`` runs the simulation's clock while it waits, so the firmware's handler can step
    through simulated time; it gives up after ``timeout`` seconds of wall time, and raises at
    once if the component exits, naming it with its exit code and last output.
    """

    def __init__(
        self,
        name: str,
        endpoint: str,
        *,
        msgtype: type[MsgT] | None,
        replytype: type[ReplyT] | None,
        timeout: float,
        watch: Watch | None,
        environment: LocalEnvironment | None,
        on_stop: Callable[[], None],
        zctx: zmq.Context[Any] | None = None,
    ) -> None:
        self.name = name
        self.endpoint = endpoint
        self.msgtype = msgtype
        self.replytype = replytype
        self.timeout = timeout
        self._watch = watch
        self._environment = environment
        self._on_stop = on_stop
        self._socket = (zctx or zmq.Context.instance()).socket(zmq.DEALER)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.connect(endpoint)
        # Checked after every lockstep step while a call runs: a poll is cheaper than a
        # non-blocking recv that raises (and Socket.poll would build a Poller per call).
        self._readable = zmq.Poller()
        self._readable.register(self._socket, zmq.POLLIN)
        self._next_id = 0
        self._stopped = False

    def send(self, msg: MsgT, *, timeout: float | None = None) -> ReplyT:
        """Send ``msg`` to the firmware and return its (validated) reply."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        if self.msgtype is not None and not isinstance(msg, self.msgtype):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(self.msgtype)} (the message type of {self.name!r})"
            )
        self._next_id += 1
        now = self._environment.scheduler.now_ns if self._environment is not None else 0
        call = wire.Call(self._next_id, type_name(type(msg)), encode(msg), now)
        self._socket.send(wire.encoder.encode(call))
        answer = self._wait(call.id, self.timeout if timeout is None else timeout)
        if isinstance(answer, wire.Failure):
            if answer.kind in ("type", "validation"):
                raise MessageTypeError("msg", msg, answer.message)
            raise RemoteError(self.name, answer.error, answer.message, answer.traceback)
        assert isinstance(answer, wire.Reply)
        if self.replytype is None:
            return msgspec.msgpack.decode(answer.payload)  # type: ignore[no-any-return]
        return decode(answer.payload, self.replytype, what=f"reply of {self.name!r}")

    def _wait(self, call_id: int, timeout: float) -> wire.Reply | wire.Failure | wire.Pong:
        deadline = time.monotonic() + timeout
        sock = self._socket
        env = self._environment
        answer: list[wire.Reply | wire.Failure | wire.Pong] = []

        readable = self._readable

        def arrived() -> bool:
            while not answer:
                if not readable.poll(0):
                    return False
                frame = wire.from_firmware.decode(sock.recv())
                if frame.id == call_id:
                    answer.append(frame)
                # Else: a late answer to a call that timed out; drop it.
            return True

        def idle() -> None:
            if env is not None:
                ready = env.idle(sock)
            else:
                ready = True if sock.poll(_SLICE_MS) else None
            if ready is None or time.monotonic() > deadline:
                self._check(deadline, timeout)

        def between() -> None:
            if time.monotonic() > deadline:
                self._check(deadline, timeout)

        if env is None:
            while not arrived():
                idle()
            return answer[0]
        scheduler = env.scheduler
        with scheduler.lock():
            # While the clock is stopped (the usual case for a plain request/reply), wait
            # on the sockets directly; the scheduler runs only once a driver activates.
            while not scheduler.running:
                idle()
                if arrived():
                    return answer[0]
            scheduler.run(arrived, idle=idle, between=between)
        return answer[0]

    def _check(self, deadline: float, timeout: float) -> None:
        watch = self._watch
        if watch is not None and watch.poll() is not None:
            raise crashed(watch, "exited while handling a message")
        if time.monotonic() > deadline:
            raise NodeTimeoutError(
                self.name,
                f"did not answer within {timeout:g} s",
                log_tail=watch.log_tail() if watch else "",
            )

    def ping(self, timeout: float = 5.0) -> wire.Pong:
        """Ask the firmware who it is (readiness check outside a simulation)."""
        self._next_id += 1
        self._socket.send(wire.encoder.encode(wire.Ping(self._next_id)))
        answer = self._wait(self._next_id, timeout)
        assert isinstance(answer, wire.Pong)
        return answer

    def stop(self) -> None:
        """Stop the component behind this node; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        self._socket.close(0)
        self._on_stop()


@dataclasses.dataclass(frozen=True)
class FirmwareProcessComponent(Generic[MsgT, ReplyT]):
    """A firmware run as a local process, reached as a CommunicationNode over ZeroMQ.

    ``command`` may contain ``{port}``; with ``port=None`` the program binds any free port
    (no collisions between parallel runs) and reports it in its handshake.
    """

    command: str | Sequence[str]
    port: int | None = None
    msgtype: type[MsgT] | None = None
    replytype: type[ReplyT] | None = None
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    cwd: str | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = 5.0

    def __post_init__(self) -> None:
        args = _split_command(self.command)
        _check_port(self.port)
        _check_types(self.msgtype, self.replytype)
        for field in ("timeout", "start_timeout", "stop_timeout"):
            _check_positive(field, getattr(self, field))
        if self.name is None:
            object.__setattr__(self, "name", default_name(args))

    def start(self, environment: LocalEnvironment) -> FirmwareNode[MsgT, ReplyT]:
        """Start the firmware process and wait for its handshake."""
        assert self.name is not None
        port = str(self.port or 0)
        args = [a.replace("{port}", port) for a in _split_command(self.command)]
        node, hello = _start_process(
            environment,
            self.name,
            args,
            env=self.env,
            cwd=self.cwd,
            handshake=True,
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
        )
        assert hello is not None
        if not hello.port:
            node.stop()
            raise NodeStartError(self.name, "joined the simulation without a firmware port")
        return FirmwareNode(
            self.name,
            f"tcp://127.0.0.1:{hello.port}",
            msgtype=self.msgtype,
            replytype=self.replytype,
            timeout=self.timeout,
            watch=node.handle,
            environment=environment,
            on_stop=node.stop,
            zctx=environment.zctx,
        )


class _ThreadWatch:
    """Watches a firmware served in a thread: it 'exits' when the thread ends."""

    def __init__(self, name: str, thread: threading.Thread, errors: list[str]) -> None:
        self.name = name
        self.thread = thread
        self.errors = errors

    def poll(self) -> int | None:
        return None if self.thread.is_alive() else (1 if self.errors else 0)

    def log_tail(self, lines: int = 40) -> str:
        return "\n".join("\n".join(self.errors).splitlines()[-lines:])


@dataclasses.dataclass(frozen=True)
class FirmwareThreadComponent(Generic[MsgT, ReplyT]):
    """A firmware served by a thread of the simulation's process, over real sockets.

    It runs exactly as in a process or a container (same server, same protocol), which makes
    it the cheapest way to test a firmware's wire behaviour.
    """

    firmware: Firmware[MsgT, ReplyT]
    replytype: type[ReplyT] | None = None
    name: str | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT
    start_timeout: float = DEFAULT_START_TIMEOUT

    def __post_init__(self) -> None:
        if not isinstance(self.firmware, Firmware):
            raise ConfigurationError("firmware", self.firmware, "a function wrapped by @firmware")
        _check_types(None, self.replytype)
        _check_positive("timeout", self.timeout)
        if self.name is None:
            object.__setattr__(self, "name", self.firmware.name)

    def start(self, environment: LocalEnvironment) -> FirmwareNode[MsgT, ReplyT]:
        """Serve the firmware in a thread and wait for its handshake."""
        from ._runtime import serve

        name = self.name
        assert name is not None
        stop = threading.Event()
        errors: list[str] = []
        coordinator = environment.coordinator

        def run() -> None:
            try:
                serve(
                    self.firmware,
                    stop=stop,
                    environment=(coordinator.address, name, environment.seed),
                )
            except BaseException:
                import traceback

                errors.append(traceback.format_exc())

        thread = threading.Thread(target=run, name=f"firmware-{name}", daemon=True)
        watch = _ThreadWatch(name, thread, errors)
        coordinator.expect(name, environment.next_order(), watch)
        thread.start()

        def halt() -> None:
            stop.set()
            thread.join(5.0)

        try:
            hello = coordinator.wait_ready(name, self.start_timeout)
        except BaseException:
            halt()
            raise
        return FirmwareNode(
            name,
            f"tcp://127.0.0.1:{hello.port}",
            msgtype=self.firmware.msgtype,
            replytype=self.replytype,
            timeout=self.timeout,
            watch=watch,
            environment=environment,
            on_stop=halt,
            zctx=environment.zctx,
        )


# -- in-process components ------------------------------------------------------------------


class InProcessFirmwareNode(Generic[MsgT, ReplyT]):
    """A firmware called directly in the caller's thread (the fastest, low-fidelity path)."""

    def __init__(
        self,
        fw: Firmware[MsgT, ReplyT],
        name: str,
        seed: int,
        environment: LocalEnvironment,
        member: Member,
    ) -> None:
        self.firmware = fw
        self.name = name
        self._seed = seed
        self._environment = environment
        self._member = member
        self._stopped = False

    def send(self, msg: MsgT) -> ReplyT:
        """Validate ``msg`` as the wire would, run the handler, return its reply."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        fw = self.firmware
        if not isinstance(msg, fw.msgtype):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(fw.msgtype)} (the message type of {self.name!r})"
            )
        try:
            checked = decode(encode(msg), fw.msgtype, what=f"message to {self.name!r}")
        except TransportError as exc:
            raise MessageTypeError("msg", msg, str(exc)) from exc
        scheduler = self._environment.scheduler
        ctx = FirmwareContext(
            self.name, self._seed, fw.period_ns, LocalDriver(scheduler, self._member)
        )
        ctx.time_ns = scheduler.now_ns
        with scheduler.lock():
            try:
                try:
                    return fw.handler(checked, ctx)
                finally:
                    ctx._finish()
            except (NodeError, SimulationStopped):
                # The harness's own failures (a participant crashed or timed out while this
                # firmware waited on the clock) surface as they would with a remote firmware.
                raise
            except Exception as exc:
                import traceback

                raise RemoteError(
                    self.name, type(exc).__name__, str(exc), traceback.format_exc()
                ) from exc

    def stop(self) -> None:
        """Nothing runs between calls; marks the node stopped."""
        self._stopped = True


@dataclasses.dataclass(frozen=True)
class InProcessFirmwareComponent(Generic[MsgT, ReplyT]):
    """A firmware run in the simulation's own process (no sockets, no threads)."""

    firmware: Firmware[MsgT, ReplyT]
    name: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.firmware, Firmware):
            raise ConfigurationError("firmware", self.firmware, "a function wrapped by @firmware")
        if self.name is None:
            object.__setattr__(self, "name", self.firmware.name)

    def start(self, environment: LocalEnvironment) -> InProcessFirmwareNode[MsgT, ReplyT]:
        """Register the firmware with the clock; it runs when a message is sent."""
        assert self.name is not None
        member = Member(self.name, environment.next_order(), None, drives=True, next_ns=None)
        environment.scheduler.add(member)
        seed = derive_seed(environment.seed, self.name)
        return InProcessFirmwareNode(self.firmware, self.name, seed, environment, member)


ParticipantT = TypeVar("ParticipantT", bound=Participant)


class ParticipantNode(Generic[ParticipantT]):
    """An in-process participant; ``participant`` is the live object (for inspection)."""

    def __init__(self, participant: ParticipantT, name: str) -> None:
        self.participant = participant
        self.name = name

    def stop(self) -> None:
        """Close the participant if it has a ``close`` method."""
        close = getattr(self.participant, "close", None)
        participant, self.participant = self.participant, None  # type: ignore[assignment]
        if close is not None and participant is not None:
            close()


@dataclasses.dataclass(frozen=True)
class ParticipantComponent(Generic[ParticipantT]):
    """A participant (world, injector) stepped in the simulation's own process."""

    factory: Callable[[], ParticipantT]
    name: str

    def start(self, environment: LocalEnvironment) -> ParticipantNode[ParticipantT]:
        """Build the participant, set it up, and schedule it from the current instant."""
        participant = self.factory()
        ctx = StepContext(self.name, derive_seed(environment.seed, self.name))
        participant.setup(ctx)
        link = LocalParticipantLink(participant, ctx)
        member = Member(
            self.name,
            environment.next_order(),
            link,
            drives=False,
            next_ns=environment.scheduler.now_ns,
        )
        environment.scheduler.add(member)
        environment.scheduler.subscribe(member, ctx._take_topics())
        return ParticipantNode(participant, self.name)


# -- simulators -----------------------------------------------------------------------------


class ProcessSimulation(NodeSet):
    """A running ProcessSimulator: nodes, the simulated clock, the run directory."""

    def __init__(self, owner: int, environment: LocalEnvironment, keep_run_dir: bool) -> None:
        super().__init__(owner, "the simulation")
        self.environment = environment
        self._keep_run_dir = keep_run_dir

    @property
    def time(self) -> float:
        """Current simulated time in seconds."""
        return self.environment.scheduler.time

    @property
    def seed(self) -> int:
        """The simulation seed."""
        return self.environment.seed

    @property
    def run_dir(self) -> Path:
        """Where component logs are written."""
        return self.environment.run_dir

    def advance(self, duration: float) -> None:
        """Run every participant for ``duration`` simulated seconds (the host drives)."""
        from ._clock import to_ns

        scheduler = self.environment.scheduler
        with scheduler.lock():
            scheduler.advance(to_ns(duration, field="duration"))

    def logs(self) -> dict[str, Path]:
        """Log files of the components that run as processes, by component name."""
        return {p.stem: p for p in sorted(self.environment.run_dir.glob("*.log"))}

    def stop(self) -> None:
        """Stop every node in reverse start order, then release the clock and sockets."""
        if self.stopped:
            return
        self.environment.scheduler.closed = True
        super().stop()

    def _finish(self) -> None:
        self.environment.close()
        if not self._keep_run_dir:
            _remove_tree(self.environment.run_dir)


class ScenarioSimulation:
    """Base of scenario simulations (rover, PX4): a running simulation with named nodes.

    Scenarios add their own attributes (``controller``, ``firmware``, ``world``); the rest
    (clock, seed, lookup, logs, stopping) is the wrapped simulation's.
    """

    def __init__(self, simulation: ProcessSimulation) -> None:
        self.simulation = simulation

    @property
    def time(self) -> float:
        """Current simulated time (s)."""
        return self.simulation.time

    @property
    def seed(self) -> int:
        """The simulation's seed."""
        return self.simulation.seed

    def get(self, node_id: NodeId[NodeT]) -> NodeT:
        """The node ``node_id`` names (ids come from the scenario simulator's ``add``)."""
        return self.simulation.get(node_id)

    def advance(self, duration: float) -> None:
        """Run the world for ``duration`` simulated seconds without a mission."""
        self.simulation.advance(duration)

    def logs(self) -> dict[str, Path]:
        """Log files of the components that run as processes or containers."""
        return self.simulation.logs()

    def stop(self) -> None:
        """Stop every node; idempotent."""
        self.simulation.stop()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


EnvT = TypeVar("EnvT", bound=LocalEnvironment)


class LocalSimulatorBase(Generic[EnvT]):
    """What the lockstep simulators share: validated settings, ``add``, starting in order."""

    def __init__(
        self,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | os.PathLike[str] | None = None,
    ) -> None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ConfigurationError("seed", seed, "a non-negative integer")
        if realtime is not None and (not isinstance(realtime, int | float) or not realtime > 0):
            raise ConfigurationError("realtime", realtime, "None or a positive speed factor")
        self.seed = seed
        self.realtime = realtime
        self.run_dir = Path(run_dir) if run_dir is not None else None
        self._token = new_simulator_token()
        self._components: list[tuple[NodeId[Any], Any]] = []
        self._names: set[str] = set()
        self._started = False

    @overload
    def add(
        self, component: Component[EnvT, NodeT], *, before: NodeId[Any] | None = None
    ) -> NodeId[NodeT]: ...
    @overload
    def add(
        self, component: Component[None, NodeT], *, before: NodeId[Any] | None = None
    ) -> NodeId[NodeT]: ...
    def add(self, component: Any, *, before: NodeId[Any] | None = None) -> NodeId[Any]:
        """Add ``component``; components start, and step within an instant, in add order.

        ``before`` places it ahead of an already added component instead of last (a scenario
        keeps its firmware last, so an injector added later still steps before it).
        """
        position = len(self._components)
        if before is not None:
            before.check_owner(self._token)
            ids = [nid for nid, _ in self._components]
            if before not in ids:
                raise ConfigurationError("before", before, "the id of a component added here")
            position = ids.index(before)
        if self._started:
            raise MulticosimError("components cannot be added after start()")
        if not callable(getattr(component, "start", None)):
            raise ConfigurationError("component", component, "an object with start(environment)")
        name = str(getattr(component, "name", None) or type(component).__name__)
        # A component may run several nodes (an attached container stack): all names count.
        names_of = getattr(component, "node_names", None)
        names = {name, *(names_of() if callable(names_of) else ())}
        for taken in sorted(names & self._names):
            raise ConfigurationError("name", taken, "a name not used by another component")
        self._names.update(names)
        node_id: NodeId[Any] = NodeId(self._token, len(self._components), name)
        self._components.insert(position, (node_id, component))
        return node_id

    def replace(self, node_id: NodeId[NodeT], component: Component[EnvT, NodeT]) -> None:
        """Swap the component ``node_id`` names for ``component`` before start (same place, id).

        For scenarios that reconfigure a component they added (a remapped sensor topic).
        """
        if self._started:
            raise MulticosimError("components cannot be replaced after start()")
        node_id.check_owner(self._token)
        for i, (nid, _) in enumerate(self._components):
            if nid == node_id:
                self._components[i] = (nid, component)
                return
        raise ConfigurationError("node_id", node_id, "the id of a component added here")

    def _new_run(self) -> tuple[str, Path]:
        """Mark the simulator started; make the run's id and directory."""
        if self._started:
            raise MulticosimError(
                "this simulator was already started; create a new simulator for another run"
            )
        self._started = True
        run_id = f"mcs-{uuid.uuid4().hex[:12]}"
        base = self.run_dir if self.run_dir is not None else runs_directory()
        run_dir = base / run_id
        run_dir.mkdir(parents=True)
        (run_dir / "owner").write_text(str(os.getpid()))
        return run_id, run_dir

    def _start_components(self, simulation: ProcessSimulation, environment: EnvT) -> None:
        """Start every component in add order; on failure stop those started, then raise."""
        try:
            for node_id, component in self._components:
                simulation._add_node(node_id, _start_component(component, environment))
        except BaseException as exc:
            try:
                simulation.stop()
            except BaseExceptionGroup as group:
                exc.add_note(f"stopping the partial simulation also failed: {group!r}")
            raise


class ProcessSimulator(LocalSimulatorBase[LocalEnvironment]):
    """The local backend: components in-process or as local processes, in lockstep.

    ``seed`` fixes every random source; ``realtime`` paces simulated time to wall time
    (None: as fast as possible); ``run_dir`` keeps logs there instead of a temporary folder.
    """

    def start(self) -> ProcessSimulation:
        """Start every component in add order; on failure stop those started, then raise."""
        run_id, run_dir = self._new_run()
        environment = LocalEnvironment(
            run_id=run_id,
            run_dir=run_dir,
            seed=self.seed,
            scheduler=Scheduler(realtime=self.realtime),
        )
        simulation = ProcessSimulation(self._token, environment, self.run_dir is not None)
        simulation._add_cleanup("the clock and sockets", simulation._finish)
        self._start_components(simulation, environment)
        return simulation


def _start_component(component: Any, environment: LocalEnvironment) -> Node:
    # Components written for no environment (``Component[None, N]``, like the paper's F16
    # example) declare it with ``environment: None``; they get None.
    if _wants_no_environment(component):
        node: Node = component.start(None)
    else:
        node = component.start(environment)
    if not isinstance(node, Node):
        raise ConfigurationError("component", component, "start() returning a node with stop()")
    return node


def _wants_no_environment(component: Any) -> bool:
    import inspect

    try:
        hints = inspect.get_annotations(type(component).start, eval_str=True)
    except Exception:
        return False
    hint = hints.get("environment", inspect.Parameter.empty)
    return hint is None or hint is type(None)


class InProcessSimulation(NodeSet):
    """A running InProcessSimulator."""


class InProcessSimulator:
    """A simulator for self-contained in-process components (``Component[None, N]``)."""

    def __init__(self) -> None:
        self._token = new_simulator_token()
        self._components: list[tuple[NodeId[Any], Component[None, Any]]] = []
        self._started = False

    def add(self, component: Component[None, NodeT]) -> NodeId[NodeT]:
        """Add ``component``; it is started with ``start(None)``."""
        name = str(getattr(component, "name", None) or type(component).__name__)
        node_id: NodeId[NodeT] = NodeId(self._token, len(self._components), name)
        self._components.append((node_id, component))
        return node_id

    def start(self) -> InProcessSimulation:
        """Start every component in add order."""
        if self._started:
            raise MulticosimError(
                "this simulator was already started; create a new simulator for another run"
            )
        self._started = True
        simulation = InProcessSimulation(self._token, "the in-process simulation")
        try:
            for node_id, component in self._components:
                simulation._add_node(node_id, component.start(None))
        except BaseException:
            simulation.stop()
            raise
        return simulation


def config_json(config: object) -> str:
    """A configuration object as JSON, for passing to a component process on its command line."""
    return msgspec.json.encode(config).decode()
