"""The cluster executor: each sample a Ray task (Ray is imported on first use, not here)."""

from __future__ import annotations

import contextlib
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import Any

from ....core.deps import require
from ....core.errors import ConfigurationError
from ..worker import Outcome, Task, run_task
from .protocol import Backend, TaskFailed, WorkerLost

__all__ = ["RayBackend", "RayExecutor"]


class RayExecutor:
    """Run samples as Ray tasks on a cluster (each uses the process backend on its worker).

    ``address`` is what ``ray.init`` takes (``"auto"``, ``"ray://head:10001"``, ...); None
    uses the running Ray connection, else starts a local cluster bound to loopback.
    ``init`` adds keyword arguments for ``ray.init``. Ray connects on first use and stays
    connected until [`shutdown`][multicosim.search.campaign.executors.ray.RayExecutor.shutdown]
    (which disconnects only what this object connected). The simulate function must be importable on
    the workers (or defined in ``__main__``); ship code to a remote cluster with a ``runtime_env``
    in ``init``.
    """

    name = "ray"

    def __init__(
        self,
        address: str | None = None,
        *,
        init: Mapping[str, Any] | None = None,
        max_in_flight: int | None = None,
    ) -> None:
        if address is not None and (not isinstance(address, str) or not address.strip()):
            raise ConfigurationError("ray_address", address, "a Ray address or None")
        if max_in_flight is not None and (
            isinstance(max_in_flight, bool)
            or not isinstance(max_in_flight, int)
            or max_in_flight < 1
        ):
            raise ConfigurationError("max_in_flight", max_in_flight, "a positive number")
        self.address = address.strip() if address is not None else None
        self.init = dict(init or {})
        self.max_in_flight = max_in_flight
        self._connected = False

    def __repr__(self) -> str:
        return f"RayExecutor(address={self.address!r})"

    def connect(self) -> ModuleType:
        """Connect to (or start) the cluster if not yet connected; return the ray module."""
        ray = require("ray", "ray")
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"address": self.address, "log_to_driver": False}
            if self.address in (None, "local"):
                kwargs.update(include_dashboard=False, _node_ip_address="127.0.0.1")
            kwargs.update(self.init)
            ray.init(**kwargs)
            self._connected = True
        return ray

    def shutdown(self) -> None:
        """Disconnect from Ray (stopping a local cluster) if this executor connected."""
        if self._connected:
            self._connected = False
            import ray

            ray.shutdown()

    def open(self) -> Backend:
        """Connect, and submit a campaign's tasks to the cluster."""
        ray = self.connect()
        cpus = int(ray.cluster_resources().get("CPU", 1)) or 1
        # A little more than the cluster runs at once keeps every worker fed between results.
        return RayBackend(ray, self.max_in_flight or 2 * cpus)


class RayBackend:
    """A connected [`RayExecutor`][multicosim.search.campaign.executors.ray.RayExecutor]: tasks
    become Ray tasks, handles object references."""

    name = "ray"

    def __init__(self, ray: ModuleType, capacity: int) -> None:
        self.capacity = capacity
        self._ray = ray
        # Retries are ours, not Ray's: counted per sample and reported.
        self._remote = ray.remote(run_task).options(max_retries=0, num_cpus=1)
        errors = ray.exceptions
        self._lost = tuple(
            getattr(errors, name)
            for name in (
                "WorkerCrashedError",
                "NodeDiedError",
                "LocalRayletDiedError",
                "ObjectLostError",
                "OwnerDiedError",
                "ActorDiedError",
            )
            if hasattr(errors, name)
        )

    def submit(self, task: Task) -> Any:
        """Start ``task`` as a Ray task; return its object reference."""
        return self._remote.remote(task)

    def wait(self, handles: Sequence[Any], timeout: float) -> list[Any]:
        """The object references of ``handles`` ready within ``timeout`` s (one at most)."""
        ready, _ = self._ray.wait(list(handles), num_returns=1, timeout=timeout)
        return list(ready)

    def outcome(self, handle: Any) -> Outcome:
        """The outcome of a ready task; WorkerLost if its worker or node died, else TaskFailed."""
        errors = self._ray.exceptions
        try:
            result: Outcome = self._ray.get(handle)
            return result
        except self._lost as exc:
            raise WorkerLost(f"{type(exc).__name__}: the worker died") from exc
        except errors.TaskCancelledError as exc:
            raise WorkerLost("cancelled") from exc
        except errors.RayError as exc:
            first = str(exc).strip().splitlines()
            raise TaskFailed(f"{type(exc).__name__}: {first[-1] if first else ''}") from exc

    def kill(self, handles: Sequence[Any]) -> None:
        """Cancel the tasks of ``handles`` (forcibly) and wait, bounded, until they stop."""
        for handle in handles:
            with contextlib.suppress(Exception):
                self._ray.cancel(handle, force=True)
        # Wait (bounded) for the cancellations to land: nothing may run after we return.
        with contextlib.suppress(Exception):
            self._ray.wait(list(handles), num_returns=len(handles), timeout=10)

    def close(self) -> None:
        """Nothing to stop: the Ray connection belongs to the executor."""
