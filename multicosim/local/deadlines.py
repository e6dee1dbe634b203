"""Deadlines for code that runs in the simulation's own thread: in-process firmware calls and
in-process participants' steps.

A process component that stops answering is noticed by the wait on its socket; code in our
own thread cannot be waited on, only interrupted. ``run_within`` runs a call under a
deadline; one daemon thread per process checks the armed calls every ``POLL`` seconds and
raises an asynchronous exception (``PyThreadState_SetAsyncExc``) in the thread of a call past
its deadline. Arming and disarming cost two dictionary updates. A call blocked inside a C
function (``time.sleep``, ``select``) is interrupted when it returns to Python.
"""

from __future__ import annotations

import ctypes
import itertools
import os
import threading
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import TypeVar, TypeVarTuple

__all__ = ["POLL", "Expired", "run_within"]

POLL = 0.1
"""How often (wall-clock seconds) the watch thread looks at the armed deadlines."""

T = TypeVar("T")
Ts = TypeVarTuple("Ts")


class _Expired(BaseException):
    """Raised asynchronously in a thread whose call ran out of time.

    A BaseException, so that the code's own ``except Exception`` does not swallow it.
    """


class Expired:
    """What ``run_within`` returns for a call it interrupted: where the call was."""

    __slots__ = ("where",)

    def __init__(self, where: str) -> None:
        self.where = where
        """The innermost line the call was running (``step at file.py:12: ...``), or ``""``."""


def _interrupt(thread_id: int, exc: type[BaseException] | None) -> None:
    # Raise ``exc`` in that thread at its next Python instruction (None: cancel a pending one).
    ctypes.pythonapi.PyThreadState_SetAsyncExc(
        ctypes.c_ulong(thread_id), None if exc is None else ctypes.py_object(exc)
    )


class _Deadlines:
    """The armed calls of this process and the thread that interrupts the late ones."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        # call -> (thread, deadline)
        self._armed: dict[int, tuple[int, float | Callable[[], float]]] = {}
        self._fired: dict[int, int] = {}  # call -> thread, until the call is forgotten
        self._settled: set[int] = set()  # fired calls whose interruption cannot come later
        self._count = itertools.count()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the watch thread (once per process)."""
        with self._lock:
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._watch, name="multicosim-deadlines", daemon=True
                )
                self._thread.start()

    def settle(self, key: int) -> None:
        """For a call the watch fired for: make sure its interruption cannot come later
        (idempotent)."""
        me = threading.get_ident()
        with self._lock:  # the watch fired: it has raised, under this lock, in our thread
            if key not in self._fired or key in self._settled:
                return
            self._settled.add(key)
            if not any(t == me and k not in self._settled for k, t in self._fired.items()):
                # Maybe not raised yet (the call returned just in time): it must not be
                # raised later, in whatever this thread runs next. (No other call of this
                # thread has fired: its interruption is not the one cancelled.)
                _interrupt(me, None)

    def forget(self, key: int) -> bool:
        """After ``settle``: whether the watch fired for call ``key``; forget the call."""
        with self._lock:
            self._settled.discard(key)
            return self._fired.pop(key, None) is not None

    def _watch(self) -> None:
        while True:
            time.sleep(POLL)
            now = time.monotonic()
            with self._lock:
                for key, (thread, deadline) in list(self._armed.items()):
                    limit = deadline() if callable(deadline) else deadline
                    # Popping is the claim: the call's own pop, or this one, wins.
                    if now > limit and self._armed.pop(key, None) is not None:
                        self._fired[key] = thread
                        _interrupt(thread, _Expired)


_deadlines = _Deadlines()
# The fast path (every in-process step goes through it) binds what it touches.
_armed = _deadlines._armed
_next_key = _deadlines._count.__next__
_thread_id = threading.get_ident


def run_within(
    deadline: float | Callable[[], float], call: Callable[[*Ts], T], *args: *Ts
) -> T | Expired:
    """``call(*args)``, interrupted once ``time.monotonic()`` passes ``deadline`` (a time, or
    a function the watch asks each time it looks: a deadline the call moves on as it makes
    progress).

    Returns the call's result, or ``Expired`` (saying where it was) if it was
    interrupted. Calls nest: an enclosing call's deadline interrupts an inner one too, and
    propagates out of it to its own ``run_within``. Costs a few dictionary operations.
    """
    key = _next_key()
    _armed[key] = (_thread_id(), deadline)  # atomic under the GIL: arming takes no lock
    if _deadlines._thread is None:
        _deadlines.start()
    fired = False
    try:
        try:
            result = call(*args)
        finally:
            if _armed.pop(key, None) is None:  # the watch claimed it first: it fired
                fired = True
                _deadlines.settle(key)
    except _Expired as exc:
        # Raised in the call or, just as it returned, in the settling above: whose was it?
        _deadlines.settle(key)
        if not _deadlines.forget(key):
            raise  # an enclosing call's deadline
        return Expired(_where(exc.__traceback__))
    if fired:
        _deadlines.forget(key)
        return Expired("")  # it returned as the watch fired: late all the same
    return result


_PACKAGE = str(Path(__file__).parent.parent) + os.sep


def _where(tb: TracebackType | None) -> str:
    # The line the late call was running: the innermost frame of the component's own code
    # (outside multicosim), else the innermost of all.
    frames = traceback.extract_tb(tb)
    own = [f for f in frames if not f.filename.startswith(_PACKAGE)]
    if not (own or frames):
        return ""
    last = (own or frames)[-1]
    line = f": {last.line.strip()}" if last.line else ""
    return f"{last.name} at {Path(last.filename).name}:{last.lineno}{line}"
