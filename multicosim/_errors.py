"""Exceptions raised by multicosim.

Every error derives from :class:`MulticosimError`, so ``except mcs.MulticosimError`` catches
anything the harness raises on its own account::

    MulticosimError
    ├── ConfigurationError        invalid input, raised before anything starts
    │   └── MessageTypeError      a message of the wrong type for a node or topic
    ├── DependencyMissingError    an optional dependency is not installed (names the extra)
    ├── NodeError                 a running component misbehaved (carries name, exit code, log)
    │   ├── NodeStartError        it did not become ready
    │   ├── NodeTimeoutError      it did not answer in time
    │   └── NodeCrashedError      it exited while it was needed
    ├── RemoteError               a component raised while handling a message
    ├── TransportError            a message could not be carried or decoded
    ├── SimulationStopped         the simulation was stopped (component side)
    └── TraceError                a trace could not be written or read

``Simulation.stop`` reports several failures at once as an ``ExceptionGroup`` of these.
"""

from __future__ import annotations

__all__ = [
    "ConfigurationError",
    "DependencyMissingError",
    "MessageTypeError",
    "MulticosimError",
    "NodeCrashedError",
    "NodeError",
    "NodeStartError",
    "NodeTimeoutError",
    "RemoteError",
    "SimulationStopped",
    "TraceError",
    "TransportError",
]


class MulticosimError(Exception):
    """Root of every error raised by multicosim."""


class ConfigurationError(MulticosimError, ValueError):
    """A configuration value is invalid; raised before anything is started.

    ``field`` names the offending field, ``value`` is what was given and ``allowed`` says
    what would have been accepted.
    """

    def __init__(self, field: str, value: object, allowed: str) -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field}={value!r} is invalid: expected {allowed}")


class MessageTypeError(ConfigurationError, TypeError):
    """A message of the wrong type was sent to a node or published on a topic."""


class DependencyMissingError(MulticosimError, ImportError):
    """An optional dependency is missing; the message names the extra to install."""

    def __init__(self, module: str, extra: str) -> None:
        self.module = module
        self.extra = extra
        super().__init__(
            f"{module!r} is required for this feature: pip install 'multicosim[{extra}]'"
        )


class NodeError(MulticosimError):
    """A running component misbehaved.

    Carries the component's ``name``, its ``exit_code`` (``None`` while it still runs or when
    unknown) and the tail of its output (``log_tail``).
    """

    def __init__(
        self,
        name: str,
        reason: str,
        *,
        exit_code: int | None = None,
        log_tail: str = "",
    ) -> None:
        self.name = name
        self.reason = reason
        self.exit_code = exit_code
        self.log_tail = log_tail
        message = f"component {name!r} {reason}"
        if exit_code is not None:
            message += f" (exit code {exit_code})"
        if log_tail:
            message += "\n--- last output ---\n" + log_tail.rstrip("\n")
        super().__init__(message)


class NodeStartError(NodeError):
    """A component failed to start or to become ready."""


class NodeTimeoutError(NodeError):
    """A component did not answer within its timeout."""


class NodeCrashedError(NodeError):
    """A component exited while the simulation needed it."""


class RemoteError(MulticosimError):
    """A component raised an exception while handling a message.

    ``name`` is the component, ``remote_type`` the exception's type name there and
    ``remote_message`` its message; ``remote_traceback`` is the formatted traceback.
    """

    def __init__(
        self, name: str, remote_type: str, remote_message: str, remote_traceback: str = ""
    ) -> None:
        self.name = name
        self.remote_type = remote_type
        self.remote_message = remote_message
        self.remote_traceback = remote_traceback
        super().__init__(f"component {name!r} raised {remote_type}: {remote_message}")


class TransportError(MulticosimError):
    """A message could not be delivered or decoded."""


class SimulationStopped(MulticosimError):
    """Raised inside a component when its simulation is stopped while it waits for a step."""


class TraceError(MulticosimError):
    """A trace could not be written or read back."""
