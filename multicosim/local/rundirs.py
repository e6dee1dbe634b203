"""Run directories and the sweep of what killed runs left behind.

Every run gets a directory (component logs) holding two records: ``owner`` (the host
process) and ``pids`` (the process groups it started), each process named by its pid *and*
its start time, so that a pid the system has since given to another process is never taken
for ours. A sweep kills the groups of runs whose host has died.

The default place, ``$TMPDIR/multicosim-UID/runs``, has a predictable name: it is used only
if it is a real directory owned by this user that no one else can write to.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import stat
import tempfile
import time
import uuid
from pathlib import Path

from ..core import wire
from ..core.errors import MulticosimError

__all__ = [
    "boot_id",
    "new_run_dir",
    "process_state",
    "record_process",
    "remove_tree",
    "runs_directory",
    "start_time",
    "sweep_stale_runs",
]


def boot_id() -> str:
    """This boot of the machine (a pid and start time are unique only within one boot)."""
    try:
        with open("/proc/sys/kernel/random/boot_id") as f:
            return f.read().strip()
    except OSError:
        return "unknown"


def _stat(pid: int) -> list[str] | None:
    # /proc/PID/stat from field 3 on: what follows the parenthesised command name (which may
    # contain spaces and parentheses itself).
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()
    except OSError:
        return None


def process_state(pid: int) -> str | None:
    """Process ``pid``'s state letter (``R`` running, ``S`` sleeping, ``T`` stopped, ...)."""
    fields = _stat(pid)
    return None if fields is None else fields[0]  # field 3


def start_time(pid: int) -> str | None:
    """When process ``pid`` started (clock ticks since boot), or None if there is none."""
    fields = _stat(pid)
    return None if fields is None else fields[19]  # field 22


# Seconds a run directory may lack its owner record (being created) before a sweep takes it
# for the leftover of a process killed while creating it.
_CREATING = 60.0


def _identity(pid: int) -> str:
    return f"{pid} {start_time(pid) or '?'} {boot_id()}"


def _same_process(record: str) -> bool | None:
    """Whether the ``pid start boot`` record names a process that still runs (None: unknown)."""
    fields = record.split()
    try:
        pid = int(fields[0])
    except (IndexError, ValueError):
        return None
    if len(fields) < 3 or fields[1] == "?":
        return None  # written where /proc is missing: nothing to compare
    return fields[2] == boot_id() and start_time(pid) == fields[1]


def _private_directory(path: Path) -> None:
    """Create ``path`` (mode 0700) or check that an existing one is this user's alone."""
    with contextlib.suppress(FileExistsError):
        os.mkdir(path, 0o700)
    info = os.lstat(path)
    problem = None
    if not stat.S_ISDIR(info.st_mode):
        problem = "is not a directory (a symbolic link or a file)"
    elif info.st_uid != os.getuid():
        problem = f"belongs to uid {info.st_uid}, not to this user (uid {os.getuid()})"
    elif info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        problem = f"can be written by other users (mode {stat.S_IMODE(info.st_mode):o})"
    if problem is not None:
        raise MulticosimError(
            f"refusing to keep runs in {path}: it {problem}; remove it, or give the simulator "
            "its own run_dir"
        )
    if stat.S_IMODE(info.st_mode) != 0o700:
        os.chmod(path, 0o700)  # ours and not writable by others: only make it private


def runs_directory() -> Path:
    """Where run directories live unless a simulator is given one (private, per user)."""
    base = Path(tempfile.gettempdir()) / f"multicosim-{os.getuid()}"
    runs = base / "runs"
    _private_directory(base)
    _private_directory(runs)
    return runs


def new_run_dir(base: Path | None) -> tuple[str, Path]:
    """A new run's id and directory (in ``base``, default
    [`runs_directory`][multicosim.local.rundirs.runs_directory])."""
    run_id = f"mcs-{uuid.uuid4().hex[:12]}"
    run_dir = (base if base is not None else runs_directory()) / run_id
    run_dir.mkdir(parents=True)
    (run_dir / "owner").write_text(_identity(os.getpid()) + "\n")
    return run_id, run_dir


def record_process(run_dir: Path, pid: int) -> None:
    """Remember a started process group so a sweep can remove it if this run is killed."""
    with open(run_dir / "pids", "a") as f:
        f.write(_identity(pid) + "\n")


def _process_run_id(pid: int) -> str | None:
    try:
        environ = Path(f"/proc/{pid}/environ").read_bytes()
    except OSError:
        return None
    for entry in environ.split(b"\0"):
        if entry.startswith(wire.ENV_RUN_ID.encode() + b"="):
            return entry.split(b"=", 1)[1].decode()
    return None


def _group_members(pgid: int, run_id: str) -> list[int]:
    """Processes still in group ``pgid`` that carry ``run_id`` (its leader may have exited)."""
    found = []
    for entry in os.listdir("/proc"):
        fields = _stat(int(entry)) if entry.isdigit() else None
        if fields is not None and int(fields[2]) == pgid and _process_run_id(int(entry)) == run_id:
            found.append(int(entry))
    return found


def _owner_alive(run_dir: Path) -> bool:
    try:
        record = (run_dir / "owner").read_text()
    except FileNotFoundError:
        # new_run_dir writes the owner just after creating the directory: another process's
        # sweep in between must not take a run being created for a dead one.
        try:
            return time.time() - os.lstat(run_dir).st_mtime < _CREATING
        except OSError:
            return False
    except OSError:
        return False
    same = _same_process(record)
    if same is None:  # an old or foreign record: trust the pid alone
        try:
            os.kill(int(record.split()[0]), 0)
        except (ValueError, IndexError, ProcessLookupError):
            return False
        except PermissionError:
            return True
        return True
    return same


def sweep_stale_runs(base: Path | None = None) -> list[int]:
    """Kill the process groups left by runs whose host process has died; return their ids.

    A group is killed if its leader is the very process the run started (same pid and start
    time), or if processes of that group still carry the run's id in their environment.
    Only run directories owned by this user are looked at.
    """
    base = base or runs_directory()
    killed: list[int] = []
    if not base.is_dir():
        return killed
    me = os.getuid()
    for run_dir in base.iterdir():
        try:
            info = os.lstat(run_dir)
        except OSError:
            continue
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != me or _owner_alive(run_dir):
            continue
        try:
            records = (run_dir / "pids").read_text().splitlines()
        except OSError:
            records = []
        for record in records:
            if not record.strip():
                continue
            pgid = int(record.split()[0])
            same = _same_process(record)
            if same is None:
                same = _process_run_id(pgid) == run_dir.name
            if same or _group_members(pgid, run_dir.name):
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(pgid, signal.SIGKILL)
                killed.append(pgid)
        remove_tree(run_dir)
    return killed


def remove_tree(path: Path) -> None:
    """Remove a directory tree, ignoring what is already gone."""
    shutil.rmtree(path, ignore_errors=True)
