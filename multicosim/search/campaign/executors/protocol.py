"""What a campaign needs of an executor once it runs: the ``Backend`` protocol.

An executor object ([`ProcessExecutor`][multicosim.search.campaign.executors.pool.ProcessExecutor],
[`RayExecutor`][multicosim.search.campaign.executors.ray.RayExecutor]) is the user's configuration;
its ``open()`` starts the workers and returns a ``Backend``, which the campaign feeds tasks until it
closes it. A backend reports a task it could not finish with ``WorkerLost`` (the campaign retries
it) or ``TaskFailed`` (it does not).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

from ..worker import Outcome, Task

__all__ = ["Backend", "TaskFailed", "WorkerLost"]


class WorkerLost(Exception):
    """The worker running a task died (or its node did)."""


class TaskFailed(Exception):
    """The task could not run at all (its function did not unpickle on the worker, say)."""


class Backend(Protocol):
    """Running workers: submit tasks, wait for some, collect their outcomes, kill, close.

    ``capacity`` is how many tasks the campaign keeps submitted at once; handles are whatever
    ``submit`` returns (futures, Ray object references).
    """

    name: str
    capacity: int

    def submit(self, task: Task) -> Any:
        """Start ``task``; return its handle."""
        ...

    def wait(self, handles: Sequence[Any], timeout: float) -> list[Any]:
        """The handles of ``handles`` that finished within ``timeout`` s (maybe none)."""
        ...

    def outcome(self, handle: Any) -> Outcome:
        """The outcome of a finished task; WorkerLost or TaskFailed if it has none."""
        ...

    def kill(self, handles: Sequence[Any]) -> None:
        """Stop the tasks of ``handles`` (and their workers if need be) before returning."""
        ...

    def close(self) -> None:
        """Stop every worker."""
        ...
