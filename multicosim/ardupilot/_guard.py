"""Run ArduPilot so that it never outlives the simulation that started it.

    python -I _guard.py BINARY ARGS...

becomes ArduPilot (same process, same pid: the simulation's peer checks and signals reach
ArduPilot itself) after forking a small watcher. ArduPilot checks its parent only between
physics steps; a simulation process killed while ArduPilot waits for a physics answer would
leave it waiting forever. The watcher sees ArduPilot handed to another parent (its parent,
the simulation's process, is gone) and stops it: SIGTERM, then SIGKILL. It exits when
ArduPilot does, and goes with ArduPilot's process group when the simulation stops it.

Run as a script (no package import: it starts in milliseconds).
"""

from __future__ import annotations

import os
import signal
import sys
import time
from typing import NoReturn

POLL = 0.5  # s between looks at ArduPilot's parent
GRACE = 2.0  # s ArduPilot gets to exit on SIGTERM


def _parent_of(pid: int) -> int | None:
    """The parent pid of ``pid``, or None once it is gone (reaped)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            stat = f.read()
    except OSError:
        return None
    # The command name may hold spaces and parentheses: fields follow the last ")".
    return int(stat.rsplit(")", 1)[1].split()[1])


def watch(firmware: int, host: int) -> None:
    """Stop ``firmware`` once ``host`` is no longer its parent; return when it is gone."""
    while True:
        time.sleep(POLL)
        parent = _parent_of(firmware)
        if parent is None:
            return
        if parent != host:
            try:
                os.kill(firmware, signal.SIGTERM)
                deadline = time.monotonic() + GRACE
                while _parent_of(firmware) is not None and time.monotonic() < deadline:
                    time.sleep(0.05)
                os.kill(firmware, signal.SIGKILL)
            except ProcessLookupError:
                pass
            return


def main(argv: list[str]) -> NoReturn:
    """Fork the watcher, then become the command ``argv``."""
    if not argv:
        raise SystemExit("usage: _guard.py BINARY ARGS...")
    host, firmware = os.getppid(), os.getpid()
    if os.fork() == 0:
        watch(firmware, host)
        os._exit(0)
    os.execv(argv[0], argv)


if __name__ == "__main__":
    main(sys.argv[1:])
