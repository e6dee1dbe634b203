"""Waits with a timeout: how often they check liveness, their defaults, and crash reports.

Every wait of the local and Docker backends has a wall-clock timeout and checks, every
``SLICE_MS``, that what it waits on (a :class:`Watch`: a process, a thread, a container) is
still alive.
"""

from __future__ import annotations

import math
import weakref
from typing import Any, Protocol

from ..core.errors import ConfigurationError, NodeCrashedError

__all__ = [
    "DEFAULT_SEND_TIMEOUT",
    "DEFAULT_START_TIMEOUT",
    "DEFAULT_STEP_TIMEOUT",
    "SLICE_MS",
    "Watch",
    "check_timeout",
    "crashed",
    "mark_reported",
    "reported",
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


# Watches whose crash has already been raised to the caller, so that stopping them later
# does not report the same crash a second time.
reported: weakref.WeakSet[Any] = weakref.WeakSet()


def crashed(watch: Watch, reason: str) -> NodeCrashedError:
    """A NodeCrashedError for ``watch`` (exit code, log tail), remembered as reported."""
    mark_reported(watch)
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
