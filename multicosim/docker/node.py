"""ContainerNode: a component running in a container (the paper's class).

Every container runs with an init process (so it stops at once on SIGTERM), carries the run's
labels (so a sweep can remove it if its host dies) and is removed when its node stops.
Public because ``multicosim.mavlink`` recognises a firmware's container (by this module's
name, without importing the Docker SDK) so that a simulation signals it with the others.
"""

from __future__ import annotations

import contextlib
import math
import os
import time
from pathlib import Path
from typing import Any

from ..core.errors import ConfigurationError, NodeCrashedError
from ..local.environment import LocalEnvironment
from ..local.rundirs import start_time
from ..local.waits import Problem, ending, memory_text, reported
from .engine import APIError, NotFound

__all__ = ["DEFAULT_STOP_TIMEOUT", "ContainerNode"]

DEFAULT_STOP_TIMEOUT = 2.0


class ContainerNode:
    """A component running in a container (the paper's ContainerNode).

    Built from a running ``docker`` SDK container; ``stop`` stops and removes it. It is also
    the liveness watch of the component: ``poll`` gives its exit code once it has exited.
    """

    def __init__(
        self,
        container: Any,
        *,
        name: str | None = None,
        stop_timeout: float = DEFAULT_STOP_TIMEOUT,
        environment: LocalEnvironment | None = None,
        log_dir: Path | None = None,
    ) -> None:
        self.container = container
        self.id: str = container.id
        self.name: str = name or container.name
        self.stop_timeout = stop_timeout
        self.ports: dict[str, int] = {}
        self._api = container.client.api
        self._environment = environment
        self._log_dir = log_dir
        self._exit_code: int | None = None
        self._last_logs = ""
        self._stopped = False
        self._early: int | None = None
        self._signalled = False
        self._pid_stat: tuple[int, str] | None = None
        self._checked = 0.0
        self.memory: int | None = None
        """Its memory limit in bytes, where known (for the error when it runs out)."""
        self.workdir = "/"
        """Its working directory in the container (where ``files`` looks)."""

    @property
    def pid(self) -> int | None:
        """Its init process's id on this machine (None where the engine is not local)."""
        return self._pid_stat[0] if self._pid_stat is not None else None

    def files(self, path: str, suffix: str, into: Path) -> list[Path]:
        """Its files ending in ``suffix`` under ``path`` (relative to its working directory),
        copied out of the container into ``into``; none where there are none (yet)."""
        import io
        import posixpath
        import tarfile

        try:
            stream, _ = self.container.get_archive(posixpath.join(self.workdir, path))
        except (NotFound, APIError):  # no such directory yet, or the container is gone
            return []
        data = io.BytesIO(b"".join(stream))
        into.mkdir(parents=True, exist_ok=True)
        with tarfile.open(fileobj=data) as tar:
            members = [m for m in tar.getmembers() if m.isfile() and m.name.endswith(suffix)]
            tar.extractall(into, members=members, filter="data")
        return sorted(into.glob(f"**/*{suffix}"))

    def _watch_pid(self, pid: int) -> None:
        # Waits check liveness every 100 ms; an engine API call for each would cost more than
        # a firmware round trip. A local engine's containers are host processes: watch the
        # init process's /proc entry (with its start time, so a recycled pid is not mistaken).
        if pid > 0 and _engine_is_local():
            start = start_time(pid)
            if start is not None:
                self._pid_stat = (pid, start)

    def poll(self) -> int | None:
        """The container's exit code once it has exited, else None."""
        if self._exit_code is not None:
            return self._exit_code
        if self._pid_stat is not None:
            # Waits poll every slice and after each reply; a death is still seen within 20 ms.
            now = time.monotonic()
            if now - self._checked < 0.02:
                return None
            pid, start = self._pid_stat
            if start_time(pid) == start:
                self._checked = now
                return None
            self._pid_stat = None  # gone: ask the engine for the exit code
        try:
            state = self._api.inspect_container(self.id)["State"]
        except NotFound:
            self._exit_code = -1  # removed behind our back
            return self._exit_code
        if state["Status"] in ("exited", "dead"):
            self._exit_code = int(state["ExitCode"])
        return self._exit_code

    def diagnose(self) -> Problem | None:
        """What the engine knows is wrong: killed at its memory limit, paused, or no longer
        on its simulation's network (see ``multicosim.local.waits``)."""
        try:
            info = self._api.inspect_container(self.id)
        except NotFound:
            return None
        state = info["State"]
        if self.memory and not state.get("OOMKilled") and state.get("ExitCode") == 137:
            # Killed with a memory limit: the engine may hear of the kernel's OOM kill only
            # after the exit it reports, so it is asked again, briefly, before it is believed.
            state = self._settled_state(state)
        if state.get("OOMKilled"):
            limit = f" of {memory_text(self.memory)}" if self.memory else ""
            return Problem("out of memory", f"killed at its container's memory limit{limit}")
        if state.get("Paused"):
            return Problem("frozen", "its container is paused")
        network = getattr(self._environment, "network", None)
        mode = info["HostConfig"].get("NetworkMode", "")
        attached = info["NetworkSettings"].get("Networks") or {}
        if network is not None and mode == network and network not in attached:
            return Problem("unreachable", f"disconnected from its simulation's network {network!r}")
        return None

    def _settled_state(self, state: dict[str, Any], wait: float = 1.0) -> dict[str, Any]:
        """The container's state once the engine says it was OOM-killed, or after ``wait`` s."""
        deadline = time.monotonic() + wait
        while not state.get("OOMKilled") and time.monotonic() < deadline:
            time.sleep(0.05)
            try:
                state = self._api.inspect_container(self.id)["State"]
            except NotFound:
                break
        return state

    def logs(self, tail: int | None = None) -> str:
        """The container's output (stdout and stderr), or its last ``tail`` lines."""
        try:
            raw: bytes = self._api.logs(self.id, tail="all" if tail is None else tail)
        except NotFound:
            text = self._last_logs
            return text if tail is None else "\n".join(text.splitlines()[-tail:])
        return raw.decode(errors="replace")

    def log_tail(self, lines: int = 40) -> str:
        """The last ``lines`` lines of its output."""
        return self.logs(tail=lines)

    def host_port(self, container_port: int | str) -> int:
        """The loopback host port that ``container_port`` (e.g. 5556 or "14540/udp") is on."""
        key = _port_key(container_port)
        if key not in self.ports:
            raise ConfigurationError("container_port", container_port, f"one of {list(self.ports)}")
        return self.ports[key]

    def stop(self) -> None:
        """Stop and remove the container; raise NodeCrashedError if it had failed before
        (unless that failure was raised already, by the wait that saw it)."""
        if self._stopped:
            return
        self._stopped = True
        if not self._signalled:
            self._signal_stop()
        early = self._early
        failure = None
        try:
            if early is None:
                # docker counts whole seconds; with an init process it exits within ~0.2 s.
                with contextlib.suppress(NotFound):
                    self._api.stop(self.id, timeout=max(1, math.ceil(self.stop_timeout)))
            if (early not in (None, 0)) or self._log_dir is not None:
                self._last_logs = self.logs()
            if self._log_dir is not None:
                (self._log_dir / f"{self.name}.log").write_text(self._last_logs)
            if early is not None and early != 0 and self not in reported:
                # Described while the engine still has the container (an OOM kill, say).
                failure = f"{ending(self)} before it was stopped"
        finally:
            _remove_container(self._api, self.id)
        if failure is not None:
            raise NodeCrashedError(self.name, failure, exit_code=early, log_tail=self.log_tail())

    def _signal_stop(self) -> None:
        # First half of stop: note whether it had already failed, then ask it to exit.
        # Signalling every container of a simulation before waiting for any makes a
        # simulation stop in the time of one container, not of all of them in turn.
        if self._signalled:
            return
        self._signalled = True
        env = self._environment
        if env is not None and env.has_coordinator:
            env.coordinator.forget(self.name)
        self._early = self.poll()
        if self._early is None:
            with contextlib.suppress(APIError):
                self._api.kill(self.id, signal="SIGTERM")

    def __repr__(self) -> str:
        return f"ContainerNode({self.name!r}, id={self.id[:12]})"


def _engine_is_local() -> bool:
    host = os.environ.get("DOCKER_HOST", "")
    return not host or host.startswith("unix://")


def _remove_container(api: Any, container_id: str) -> None:
    try:
        api.remove_container(container_id, force=True, v=True)
    except NotFound:
        pass
    except APIError as exc:
        # Removal already in progress (the engine is stopping it): that is what we want.
        if exc.status_code != 409:
            raise


def _port_key(port: int | str) -> str:
    text = str(port)
    number, _, proto = text.partition("/")
    proto = proto or "tcp"
    if not number.isdigit() or not 1 <= int(number) <= 65535 or proto not in ("tcp", "udp"):
        raise ConfigurationError(
            "port", port, "a port number 1..65535, optionally '/tcp' or '/udp'"
        )
    return f"{int(number)}/{proto}"
