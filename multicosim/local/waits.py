"""Waits with a timeout: how often they check liveness, their defaults, and crash reports.

Every wait of the local and Docker backends has a wall-clock timeout and checks, every
``SLICE_MS``, that what it waits on (a [`Watch`][multicosim.local.waits.Watch]: a process, a thread,
a container) is still alive. When it is not, or does not answer in time, the error names the fault
in the same words whatever the backend ([`ending`][multicosim.local.waits.ending],
[`stalled`][multicosim.local.waits.stalled]): the component *exited* (exit code 0), *crashed*
(killed by a signal, an exception, another exit code), *ran out of memory*, is *frozen* (stopped,
paused) or *unreachable* (disconnected from its network).
"""

from __future__ import annotations

import math
import re
import signal
import weakref
from typing import Any, NamedTuple, Protocol

from ..core.errors import ConfigurationError, NodeCrashedError

__all__ = [
    "DEFAULT_SEND_TIMEOUT",
    "DEFAULT_START_TIMEOUT",
    "DEFAULT_STEP_TIMEOUT",
    "SLICE_MS",
    "Problem",
    "Watch",
    "check_timeout",
    "crashed",
    "ending",
    "mark_reported",
    "memory_bytes",
    "memory_text",
    "reported",
    "stalled",
]

SLICE_MS = 100  # how often a wait checks liveness and deadlines
DEFAULT_SEND_TIMEOUT = 120.0
DEFAULT_START_TIMEOUT = 30.0
DEFAULT_STEP_TIMEOUT = 60.0


class Watch(Protocol):
    """Something whose liveness a wait can check: a process or a container."""

    name: str

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        ...

    def log_tail(self, lines: int = 40) -> str:
        """The last lines of its output."""
        ...


class Problem(NamedTuple):
    """What a watch knows is wrong with it beyond its exit code (see ``diagnose``)."""

    fault: str  # "frozen", "unreachable" or "out of memory"
    detail: str  # how it is known: "its process is stopped (SIGSTOP)", ...


def diagnose(watch: object) -> Problem | None:
    """The watch's own diagnosis (``watch.diagnose()``, where it has one), else None.

    Processes know when they are stopped; containers when they are paused, out of memory
    (the engine's OOM kill) or disconnected from their simulation's network.
    """
    method = getattr(watch, "diagnose", None)
    try:
        problem = method() if callable(method) else None
    except Exception:  # a diagnosis only adds words to an error already on its way
        return None
    return problem if isinstance(problem, Problem) else None


# A Python traceback's last line: the exception raised (a ``raise`` in a component's setup
# or step ends its process with this in its log).
_RAISED = re.compile(r"^(?:[A-Za-z_][\w.]*\.)?([A-Z]\w*(?:Error|Exception|Exit|Interrupt)\b.*)$")


def _raised(log_tail: str) -> str | None:
    if "Traceback (most recent call last):" not in log_tail:
        return None
    lines = [line for line in log_tail.splitlines() if line.strip()]
    found = _RAISED.match(lines[-1]) if lines else None
    return found.group(1) if found else None


def _signal_name(code: int) -> str | None:
    # -N: a local process killed by signal N; 128+N: a shell's or a container's report of it.
    number = -code if code < 0 else code - 128 if 128 < code < 128 + 65 else 0
    try:
        return signal.Signals(number).name if number else None
    except ValueError:
        return None


def ending(watch: Watch) -> str | None:
    """How ``watch`` ended, in the words errors use; None while it still runs.

    ``ran out of memory (...)``; ``became unreachable (...) and exited``; ``crashed (killed
    by SIGKILL)`` or ``crashed (it raised ValueError: ...)`` (a Python traceback in its
    output); else ``exited`` (the error adds the exit code).
    """
    code = watch.poll()
    if code is None:
        return None
    problem = diagnose(watch)
    raised = _raised(watch.log_tail())
    if problem is not None and problem.fault == "out of memory":
        return f"ran out of memory ({problem.detail})"
    if raised is not None and raised.startswith("MemoryError"):
        limit = getattr(watch, "memory", None)
        within = f"over its limit of {memory_text(limit)}" if limit else "it raised MemoryError"
        return f"ran out of memory ({within})"
    if problem is not None and problem.fault == "unreachable":
        return f"became unreachable ({problem.detail}) and exited"
    name = _signal_name(code) if code != 0 else None
    if name is not None:
        return f"crashed (killed by {name})"
    if raised is not None and code != 0:
        return f"crashed (it raised {raised})"
    return "exited"


def stalled(watch: object) -> str:
    """Why a live ``watch`` does not answer, where it knows: ``": it is frozen (...)"``.

    Empty when nothing is known (it is busy, or blocked on something of its own).
    """
    problem = diagnose(watch)
    if problem is None or problem.fault == "out of memory":
        return ""
    return f": it is {problem.fault} ({problem.detail})"


# Watches whose crash has already been raised to the caller, so that stopping them later
# does not report the same crash a second time.
reported: weakref.WeakSet[Any] = weakref.WeakSet()


def crashed(watch: Watch, when: str, detail: str = "") -> NodeCrashedError:
    """A NodeCrashedError for ``watch`` (how it ended, exit code, log tail), remembered as
    reported.

    ``when`` says where the run was (``"during its step at t=1.2 s"``); ``detail`` what was
    seen of it (``"it closed the simulator connection"``), and is the whole story if the
    watch still runs.
    """
    mark_reported(watch)
    verdict = ending(watch)
    if verdict is None:
        reason = f"{detail or 'failed'} {when}"
    else:
        reason = f"{verdict} {when}" + (f": {detail}" if detail else "")
    return NodeCrashedError(watch.name, reason, exit_code=watch.poll(), log_tail=watch.log_tail())


def mark_reported(watch: object) -> None:
    """Remember that ``watch``'s exit was raised already (stopping it will not raise it again)."""
    reported.add(getattr(watch, "handle", watch))


def check_timeout(field: str, value: object) -> None:
    """Raise ConfigurationError unless ``value`` is a positive, finite number of seconds."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or not value > 0
    ):
        raise ConfigurationError(field, value, "a positive, finite number of seconds")


_SIZE = re.compile(r"(\d+)([bkmg]?)", re.IGNORECASE)
_UNITS = {"": 1, "b": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30}


def memory_bytes(value: object, minimum: int = 1 << 20) -> int | None:
    """A memory size as bytes (an integer, or ``"512m"``, ``"2g"``); None if invalid or
    below ``minimum``. What process and container memory limits accept."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        size = value
    elif isinstance(value, str) and (found := _SIZE.fullmatch(value.strip())):
        size = int(found.group(1)) * _UNITS[found.group(2).lower()]
    else:
        return None
    return size if size >= minimum else None


def memory_text(size: int) -> str:
    """``size`` bytes for a message: ``"256 MiB"``, ``"2 GiB"``."""
    for unit, factor in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if size >= factor:
            return f"{size / factor:.4g} {unit}"
    return f"{size} bytes"
