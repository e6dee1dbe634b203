"""The local executor: a ``concurrent.futures`` pool of forkserver (or spawn) processes.

Tasks travel by cloudpickle, so that a ``simulate`` defined in a notebook or in ``python -``
(a ``__main__`` the workers cannot import) runs there as it would on Ray.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import multiprocessing
import os
import sys
from collections.abc import Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from ....core.errors import ConfigurationError
from ..worker import Outcome, Task, pickled, run_pickled, worker_init
from .protocol import Backend, TaskFailed, WorkerLost

__all__ = ["PoolBackend", "ProcessExecutor"]


class ProcessExecutor:
    """Run samples in a local pool of ``workers`` processes (default: one per core).

    ``context`` is the multiprocessing start method: ``forkserver`` (default) or ``spawn``;
    fork is refused because a forked ZeroMQ context is unsafe.
    """

    name = "process"

    def __init__(self, workers: int | None = None, *, context: str = "forkserver") -> None:
        if workers is not None and (
            isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
        ):
            raise ConfigurationError("workers", workers, "a positive number of processes")
        if context not in ("forkserver", "spawn"):
            raise ConfigurationError("context", context, "'forkserver' or 'spawn'")
        self.workers = workers or os.cpu_count() or 1
        self.context = context

    def __repr__(self) -> str:
        return f"ProcessExecutor(workers={self.workers}, context={self.context!r})"

    def open(self) -> Backend:
        """The pool for one campaign (its processes start with the first task)."""
        return PoolBackend(self.workers, self.context)


@contextlib.contextmanager
def _main_without_file() -> Iterator[None]:
    """Hide a ``__main__.__file__`` that names no file (``python -`` has ``<stdin>``).

    A new worker runs the main module's file again before its first task; there is none to
    run, and the task brings what it needs of ``__main__`` by value.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or os.path.isfile(path):
        yield
        return
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path


class PoolBackend:
    """A [`ProcessExecutor`][multicosim.search.campaign.executors.pool.ProcessExecutor]'s running
    pool; a broken pool is replaced on the next task."""

    name = "process"

    def __init__(self, workers: int, context: str) -> None:
        self.capacity = workers
        self._workers = workers
        self._context = multiprocessing.get_context(context)
        self._pool: concurrent.futures.ProcessPoolExecutor | None = None
        # Which pool ran a future: a broken pool must not take its replacement down with it.
        self._owner: dict[concurrent.futures.Future[Outcome], Any] = {}

    def submit(self, task: Task) -> concurrent.futures.Future[Outcome]:
        """Start ``task`` in the pool (a new pool if the last one broke); return its future."""
        if self._pool is None:
            self._pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=self._workers, mp_context=self._context, initializer=worker_init
            )
        payload = pickled(task)
        with _main_without_file():  # processes start here, on demand
            future = self._pool.submit(run_pickled, payload)
        self._owner[future] = self._pool
        return future

    def wait(self, handles: Sequence[Any], timeout: float) -> list[Any]:
        """The futures of ``handles`` done within ``timeout`` s."""
        done, _ = concurrent.futures.wait(
            handles, timeout=timeout, return_when=concurrent.futures.FIRST_COMPLETED
        )
        return list(done)

    def outcome(self, handle: Any) -> Outcome:
        """The outcome of a done future; WorkerLost if its pool broke, else TaskFailed."""
        pool = self._owner.pop(handle, None)
        try:
            result: Outcome = handle.result()
            return result
        except BrokenProcessPool as exc:
            self._discard(pool)
            raise WorkerLost("a worker process died (the pool broke)") from exc
        except concurrent.futures.CancelledError as exc:
            raise WorkerLost("cancelled with its worker") from exc
        except Exception as exc:  # pickling the task or its result failed
            raise TaskFailed(f"{type(exc).__name__}: {exc}") from exc

    def _discard(self, pool: concurrent.futures.ProcessPoolExecutor | None) -> None:
        current = self._pool
        if pool is None or pool is not current:
            return  # an older pool: its replacement is running other tasks
        self._pool = None
        pool.shutdown(wait=False, cancel_futures=True)

    def kill(self, handles: Sequence[Any]) -> None:
        """Kill the processes of the pools running ``handles`` (and with them, those pools)."""
        pools = {id(p): p for h in handles if (p := self._owner.get(h)) is not None}
        for pool in pools.values():
            # No public way to stop a running task: end the processes, and with them the pool.
            processes = list(getattr(pool, "_processes", {}).values())
            for process in processes:
                with contextlib.suppress(OSError):
                    process.kill()
            for process in processes:
                process.join(timeout=10)
            self._discard(pool)

    def close(self) -> None:
        """Shut the pool down, cancelling what has not started."""
        pool = self._pool
        self._pool = None
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
