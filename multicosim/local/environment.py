"""The environment a ProcessSimulator gives its components: clock, coordinator, seed, run dir."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

import zmq

from ..core import wire
from ..core.clock import Scheduler
from .coordinator import Coordinator
from .rundirs import record_process
from .waits import DEFAULT_STEP_TIMEOUT, SLICE_MS

__all__ = ["LocalEnvironment", "StartedProcess"]


class StartedProcess(Protocol):
    """A component process as its environment lists it (a ``ProcessHandle``)."""

    name: str
    pid: int

    def read_log(self, last: int | None = None) -> bytes:
        """Its output so far (the ``last`` bytes of it)."""
        ...

    def restore_log(self) -> None:
        """Write its log file again if it was removed while the process ran."""
        ...


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
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        self.run_id = run_id
        self.run_dir = run_dir
        self.seed = seed
        self.scheduler = scheduler
        self.zctx: zmq.Context[Any] = zmq.Context()
        self._coordinator_host = coordinator_host
        self.step_timeout = step_timeout
        self._coordinator: Coordinator | None = None
        self._order = 0
        self.processes: dict[str, StartedProcess] = {}
        """The component processes started, by name (their logs, for reports)."""

    @property
    def coordinator(self) -> Coordinator:
        """The coordinator socket, bound on first use."""
        if self._coordinator is None:
            self._coordinator = Coordinator(
                self.scheduler,
                self.zctx,
                self._coordinator_host,
                step_timeout=self.step_timeout,
            )
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
        """Environment variables that place a component process in this simulation.

        They include the component's secret token: environment variables, unlike command
        lines, are not readable by other users' processes.
        """
        return {
            wire.ENV_COORDINATOR: self.coordinator.address,
            wire.ENV_NODE_NAME: name,
            wire.ENV_SEED: str(self.seed),
            wire.ENV_RUN_ID: self.run_id,
            wire.ENV_TOKEN: self.coordinator.token(name),
        }

    def record_pid(self, pid: int) -> None:
        """Remember a started process group so a sweep can remove it if this run is killed."""
        record_process(self.run_dir, pid)

    def idle(self, extra: zmq.Socket[Any]) -> bool | None:
        """Wait a slice for frames (see ``Coordinator.pump``); check participants when quiet."""
        if self._coordinator is None:
            return True if extra.poll(SLICE_MS) else None
        ready = self._coordinator.pump(SLICE_MS, extra)
        if ready is None:
            self._coordinator.check_alive()
        return ready

    def close(self) -> None:
        """Close sockets."""
        if self._coordinator is not None:
            self._coordinator.close()
        self.zctx.destroy(linger=0)
