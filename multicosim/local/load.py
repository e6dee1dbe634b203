"""Extra CPU load: busy processes that a soak or ``--mcs-repeat-load`` runs beside a test."""

from __future__ import annotations

import subprocess
import sys
from types import TracebackType

from ..core.errors import ConfigurationError
from .processes import before_exec

__all__ = ["CpuLoad"]


class CpuLoad:
    """``processes`` busy Python loops, stopped on the way out (a context manager).

    Each dies with its host (SIGKILL to the host included, on Linux) and has its own process
    group, so neither a killed run nor Ctrl-C in a terminal leaves one spinning.
    """

    def __init__(self, processes: int) -> None:
        if not isinstance(processes, int) or isinstance(processes, bool) or processes < 0:
            raise ConfigurationError("processes", processes, "an integer >= 0")
        self.processes = processes
        self._spinners: list[subprocess.Popen[bytes]] = []

    def start(self) -> CpuLoad:
        """Start the busy processes (again a no-op while they run)."""
        while len(self._spinners) < self.processes:
            self._spinners.append(
                subprocess.Popen(
                    [sys.executable, "-c", "while True: pass"],
                    stdin=subprocess.DEVNULL,
                    start_new_session=True,
                    preexec_fn=before_exec(None),
                )
            )
        return self

    def stop(self) -> None:
        """Kill them and wait for each; idempotent."""
        spinners, self._spinners = self._spinners, []
        for p in spinners:
            p.kill()
        for p in spinners:
            p.wait(10)

    @property
    def running(self) -> int:
        """How many are running now."""
        return sum(p.poll() is None for p in self._spinners)

    def __enter__(self) -> CpuLoad:
        return self.start()

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.stop()
