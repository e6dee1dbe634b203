"""Run directories and the sweep of what killed runs left behind."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
from pathlib import Path

from . import _wire as wire

__all__ = ["remove_tree", "runs_directory", "sweep_stale_runs"]


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
        remove_tree(run_dir)
    return killed


def remove_tree(path: Path) -> None:
    """Remove a directory tree, ignoring what is already gone."""
    shutil.rmtree(path, ignore_errors=True)
