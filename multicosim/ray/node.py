"""A component's program on a Ray node, as this process sees it: watched, logged, stopped.

``RemoteProgram`` is the handle of one [`ComponentHost`][multicosim.ray.host.ComponentHost] actor:
what the coordinator polls while it waits (has the program exited? its output?), asking the actor
with a timeout each time, and what stops it (the program, then the actor, until Ray confirms
the actor is gone). [`RayNode`][multicosim.ray.node.RayNode] is a participant's node;
[`RayFirmwareNode`][multicosim.ray.node.RayFirmwareNode] a firmware's, reached over ZeroMQ at its
node's address.
"""

from __future__ import annotations

import logging
import signal
import time
from pathlib import Path
from typing import Any

from ..core.errors import NodeCrashedError, NodeStartError
from ..core.interfaces import Node
from ..core.messages import MsgT, ReplyT
from ..local import LocalEnvironment, ProcessFirmwareNode
from ..local.waits import Problem, ending, reported
from .host import Placed

__all__ = ["ASK_TIMEOUT", "RayFirmwareNode", "RayNode", "RemoteProgram"]

log = logging.getLogger(__name__)

ASK_TIMEOUT = 5.0
"""How long (s) an actor may take to answer a question about its program."""

KILL_TIMEOUT = 10.0
"""How long (s) Ray may take to confirm that a killed actor is gone."""

LOST = -signal.SIGKILL
"""The exit code of a program whose actor died: it was killed with it."""

_TAIL_BYTES = 16384


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__


class RemoteProgram:
    """A component's program run by its actor on a Ray node; ``pid`` is its process id there.

    Each question goes to the actor and waits at most ``ASK_TIMEOUT`` seconds; an actor that
    does not answer counts as running (the step's own timeout ends the wait), one that died
    as a program that was killed (its node or worker is gone). The output is kept here once
    the program has ended, so that a report can still show it after the actor has gone.
    """

    def __init__(self, name: str, actor: Any, ray: Any, log_path: Path) -> None:
        self.name = name
        self.actor = actor
        self.log_path = log_path
        """Where ``restore_log`` (``simulation.logs()``) and stopping write its output."""
        self._ray = ray
        self.pid = 0
        """The program's process id on its node (once started)."""
        self._placed: Placed | None = None
        self._code: int | None = None
        self._lost = ""  # why the actor is gone, once it is
        self._silent = False  # the actor did not answer the last question
        self._output = b""  # the output last read from the actor
        self._final = False  # the output is all there will be
        self._stopped = False

    # -- where it runs ------------------------------------------------------------------------

    @property
    def placed(self) -> Placed:
        """Where its program was started (once ``start`` has returned)."""
        if self._placed is None:
            raise RuntimeError(f"{self.name} has not been started")
        return self._placed

    @property
    def node_id(self) -> str:
        """The Ray id of the node it runs on."""
        return self.placed.node_id

    @property
    def node_ip(self) -> str:
        """The address of the node it runs on."""
        return self.placed.node_ip

    @property
    def worker_pid(self) -> int:
        """The process id of its actor (a Ray worker) on that node."""
        return self.placed.worker_pid

    # -- starting and asking ------------------------------------------------------------------

    def _ask(self, method: Any, *args: Any, timeout: float = ASK_TIMEOUT) -> Any:
        """The answer of the actor's ``method`` (``self.actor.poll``, ...) within ``timeout``."""
        return self._ray.get(method.remote(*args), timeout=timeout)

    def start(self, args: list[str], env: dict[str, str], path: list[str], timeout: float) -> None:
        """Have the actor start ``python -m ARGS`` on its node: Ray places the actor first, so
        this waits up to ``timeout`` s for a node with room for it."""
        errors = self._ray.exceptions
        try:
            self._placed = Placed(*self._ask(self.actor.start, args, env, path, timeout=timeout))
            self.pid = self._placed.pid
        except errors.GetTimeoutError as exc:
            raise NodeStartError(
                self.name,
                f"was not running on the Ray cluster within {timeout:g} s: no node may have "
                "room for it (the resources its actor asks for) or its worker is slow to start",
            ) from exc
        except errors.RayError as exc:
            raise NodeStartError(
                self.name, f"could not be started on the Ray cluster: {_first_line(exc)}"
            ) from exc
        log.info("%s runs on Ray node %s (%s)", self.name, self.node_id[:12], self.node_ip)

    def poll(self) -> int | None:
        """The program's exit code once it has exited (``LOST`` if its actor died), else None."""
        if self._code is not None:
            return self._code
        errors = self._ray.exceptions
        try:
            code: int | None = self._ask(self.actor.poll)
        except errors.GetTimeoutError:
            self._silent = True
            return None
        except errors.RayActorError as exc:
            self._lost = _first_line(exc)
            self._code = LOST
            return self._code
        self._silent = False
        if code is not None:
            self._code = code
            self._keep_output()
        return code

    def diagnose(self) -> Problem | None:
        """Unreachable if its actor died or does not answer; frozen if its program is stopped."""
        if self._lost:
            return Problem("unreachable", f"its Ray actor is gone: {self._lost}")
        if self._silent:
            return Problem("unreachable", f"its Ray actor did not answer within {ASK_TIMEOUT:g} s")
        try:
            if self._ask(self.actor.frozen):
                return Problem("frozen", "its process is stopped, as by SIGSTOP")
        except self._ray.exceptions.RayError:
            return None
        return None

    def read_log(self, last: int | None = None) -> bytes:
        """Its output so far (the ``last`` bytes of it); what was last read if the actor is
        gone or does not answer."""
        if not self._final and not self._lost:
            try:
                output: bytes = self._ask(self.actor.read_log, None)
                self._output = output
            except self._ray.exceptions.RayError as exc:
                log.debug("%s: its output could not be read: %s", self.name, _first_line(exc))
        return self._output if last is None else self._output[-last:]

    def log_tail(self, lines: int = 40) -> str:
        """The last ``lines`` lines of its output."""
        text = self.read_log(_TAIL_BYTES).decode(errors="replace")
        return "\n".join(text.splitlines()[-lines:])

    def restore_log(self) -> None:
        """Write its output so far to ``log_path`` (on this machine)."""
        output = self.read_log()
        self.log_path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        self.log_path.write_bytes(output)

    def _keep_output(self) -> None:
        self.read_log()
        self._final = True

    # -- stopping -----------------------------------------------------------------------------

    def terminate(self, timeout: float) -> None:
        """Stop the program (TERM, ``timeout`` s, KILL), keep its output, then kill the actor
        and wait, bounded, until Ray confirms it is gone; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        errors = self._ray.exceptions
        try:
            if self._placed is not None and not self._lost:
                self._ask(self.actor.terminate, timeout, timeout=timeout + ASK_TIMEOUT)
                self._keep_output()
        except errors.RayError as exc:
            log.warning("%s: its program could not be stopped: %s", self.name, _first_line(exc))
        finally:
            self._kill_actor()

    def _kill_actor(self) -> None:
        ray, errors = self._ray, self._ray.exceptions
        try:
            ray.kill(self.actor, no_restart=True)
        except errors.RayError as exc:
            log.debug("%s: killing its actor: %s", self.name, _first_line(exc))
        # Killing is asynchronous: the actor is gone once a question to it fails.
        deadline = time.monotonic() + KILL_TIMEOUT
        while time.monotonic() < deadline:
            try:
                self._ask(self.actor.poll, timeout=max(0.01, deadline - time.monotonic()))
            except errors.RayActorError:
                return
            except errors.GetTimeoutError:
                break
            time.sleep(0.01)
        log.warning(
            "%s: Ray did not confirm within %g s that its actor is gone", self.name, KILL_TIMEOUT
        )


class RayNode:
    """A participant running on a Ray node: its program, watched through its actor."""

    def __init__(
        self, handle: RemoteProgram, stop_timeout: float, environment: LocalEnvironment
    ) -> None:
        self.handle = handle
        self.name = handle.name
        self._stop_timeout = stop_timeout
        self._environment = environment
        self._stopped = False

    @property
    def pid(self) -> int:
        """Its program's process id on its node."""
        return self.handle.pid

    @property
    def node_id(self) -> str:
        """The Ray id of the node it runs on."""
        return self.handle.node_id

    @property
    def node_ip(self) -> str:
        """The address of the node it runs on."""
        return self.handle.node_ip

    @property
    def actor(self) -> Any:
        """Its Ray actor (a [`ComponentHost`][multicosim.ray.host.ComponentHost])."""
        return self.handle.actor

    @property
    def log_path(self) -> Path:
        """Where its output is written on this machine (``simulation.logs()``, stopping)."""
        return self.handle.log_path

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        return self.handle.poll()

    def log_tail(self, lines: int = 40) -> str:
        """The last lines of its output."""
        return self.handle.log_tail(lines)

    def diagnose(self) -> Problem | None:
        """What is known to be wrong with it (see ``RemoteProgram.diagnose``)."""
        return self.handle.diagnose()

    def stop(self) -> None:
        """Stop its program and actor; raise NodeCrashedError if it had failed before."""
        if self._stopped:
            return
        self._stopped = True
        if self._environment.has_coordinator:
            self._environment.coordinator.forget(self.name)
        handle = self.handle
        early = handle.poll()
        failed = early is not None and early != 0 and handle not in reported
        verdict = ending(handle) if failed else None
        handle.terminate(self._stop_timeout)
        if handle.log_path.parent.exists():
            handle.restore_log()
        if failed:
            raise NodeCrashedError(
                self.name,
                f"{verdict} before it was stopped",
                exit_code=early,
                log_tail=handle.log_tail(),
            )


class RayFirmwareNode(ProcessFirmwareNode[MsgT, ReplyT]):
    """A firmware on a Ray node: a CommunicationNode over ZeroMQ at its node's address.

    ``program`` is its [`RayNode`][multicosim.ray.node.RayNode] (output, exit code, the node it runs
    on).
    """

    def __init__(
        self,
        program: RayNode,
        endpoint: str,
        environment: LocalEnvironment,
        *,
        msgtype: type[MsgT] | None,
        replytype: type[ReplyT] | None,
        timeout: float,
    ) -> None:
        super().__init__(
            program.name,
            endpoint,
            msgtype=msgtype,
            replytype=replytype,
            timeout=timeout,
            watch=program.handle,
            environment=environment,
            on_stop=program.stop,
            zctx=environment.zctx,
            token=environment.coordinator.token(program.name),
        )
        self.program = program

    @property
    def node_id(self) -> str:
        """The Ray id of the node it runs on."""
        return self.program.node_id

    def parts(self) -> list[Node]:
        """Its program's node."""
        return [self.program]
