"""SIGTERM handled as Ctrl-C while simulations run, so that teardown stops them.

CI systems cancel a job with SIGTERM, whose default action ends pytest at once: fixture
teardown never runs and containers outlive the run (local component processes die with it
on Linux). Once a test uses the plugin's simulation fixtures, the first SIGTERM raises
KeyboardInterrupt instead, which pytest answers as it answers Ctrl-C: the test stops, every
fixture is torn down, the session ends as interrupted. Further SIGTERMs are logged and
ignored until teardown is done (SIGKILL still ends everything).
"""

from __future__ import annotations

import logging
import signal
import threading
from types import FrameType
from typing import Any

__all__ = ["SigtermAsInterrupt"]

log = logging.getLogger(__name__)


class SigtermAsInterrupt:
    """Installs (once) and removes the SIGTERM handler of a pytest session."""

    def __init__(self) -> None:
        self._previous: Any = None
        self._installed = False
        self._received = False

    def install(self) -> None:
        """Handle SIGTERM as Ctrl-C from now on, unless someone else already handles it."""
        if self._installed or threading.current_thread() is not threading.main_thread():
            return
        if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
            return  # the user's own handler (or another plugin's) wins
        self._previous = signal.signal(signal.SIGTERM, self._handle)
        self._installed = True

    def uninstall(self) -> None:
        """Give SIGTERM back its previous handler (if ours is still installed)."""
        if not self._installed:
            return
        self._installed = False
        if (
            threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGTERM) == self._handle
        ):
            signal.signal(signal.SIGTERM, self._previous)

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self._received:
            log.warning("SIGTERM again: still stopping the simulations (SIGKILL ends at once)")
            return
        self._received = True
        log.warning("SIGTERM: stopping the test run as on Ctrl-C; tearing down simulations")
        raise KeyboardInterrupt("SIGTERM")
