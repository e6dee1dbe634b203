"""Where a campaign's samples run: one module per executor, behind ``protocol``.

* ``pool``: [`ProcessExecutor`][multicosim.search.campaign.executors.ProcessExecutor], a local
  process pool (the default);
* [`ray`][multicosim.ray]: [`RayExecutor`][multicosim.search.campaign.executors.RayExecutor], Ray
  tasks on a cluster.

``executor_of`` turns a campaign's ``executor=`` and ``ray_address=`` arguments into one
of them.
"""

from __future__ import annotations

from ....core.errors import ConfigurationError
from .pool import ProcessExecutor
from .protocol import Backend, TaskFailed, WorkerLost
from .ray import RayExecutor

__all__ = [
    "Backend",
    "ExecutorSpec",
    "ProcessExecutor",
    "RayExecutor",
    "TaskFailed",
    "WorkerLost",
    "executor_of",
]

ExecutorSpec = str | ProcessExecutor | RayExecutor | None


def executor_of(executor: ExecutorSpec, ray_address: str | None) -> ProcessExecutor | RayExecutor:
    """The executor that ``executor`` (a name, an executor or None) and ``ray_address`` mean."""
    if isinstance(executor, ProcessExecutor | RayExecutor):
        if ray_address is not None:
            raise ConfigurationError("ray_address", ray_address, "None with an executor object")
        return executor
    if executor is None:
        executor = "ray" if ray_address is not None else "process"
    if executor == "process":
        if ray_address is not None:
            raise ConfigurationError("ray_address", ray_address, "None with executor='process'")
        return ProcessExecutor()
    if executor == "ray":
        return RayExecutor(ray_address)
    raise ConfigurationError(
        "executor", executor, "'process', 'ray', a ProcessExecutor or a RayExecutor"
    )
