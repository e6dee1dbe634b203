"""The error an FMU's own failure raises: which FMU, which call, what status, when."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..core.errors import NodeError

if TYPE_CHECKING:
    from .model import Model

__all__ = ["FMUError"]


class FMUError(NodeError):
    """An FMU answered an FMI call with Discard, Error or Fatal (or its solver failed).

    A [`multicosim.NodeError`][multicosim.NodeError]: ``name`` is the component, ``function`` the
    FMI call (``fmi2DoStep``, ``fmi3DoStep``, ...), ``status`` what it returned, ``time`` the
    simulated time (s) of the step and ``fmu_time`` the FMU's own (they differ by the FMU's
    ``start_time``) and ``fmu_reason`` the reason the FMU logged with its Error or Fatal
    status (its last such line: the message ends with it). The run stops there and the
    instance is freed. Run as a process or a
    container, the same failure ends the component's program, and the host reports a
    NodeCrashedError whose log tail holds this error and the FMU's own log.
    """

    def __init__(
        self,
        name: str,
        model: Model | str,
        function: str,
        status: str,
        time: float,
        *,
        fmu_time: float | None = None,
        log_tail: str = "",
    ) -> None:
        self.function = function
        self.status = status
        self.time = time
        self.fmu_time = time if fmu_time is None else fmu_time
        self.fmu = model if isinstance(model, str) else model.label
        self.fmu_reason = ""
        when = f"at t={time:.9g} s"
        if self.fmu_time != time:
            when += f" (the FMU's time {self.fmu_time:.9g} s)"
        self._failed = f"(FMU {self.fmu}) failed: {function} returned {status} {when}"
        super().__init__(name, self._failed, log_tail=log_tail)

    def add_log(self, lines: Sequence[str], reason: str) -> None:
        """Attach the FMU's own log: its last ``lines``, and the ``reason`` it gave (the
        message of its last Error or Fatal line; empty if it gave none)."""
        self.fmu_reason = reason
        failed = f"{self._failed}: {reason}" if reason else self._failed
        NodeError.__init__(self, self.name, failed, log_tail="\n".join(lines))
