"""Exceptions raised by multicosim.

Every error derives from [`MulticosimError`][multicosim.core.errors.MulticosimError], so ``except
mcs.MulticosimError`` catches anything the harness raises on its own account:

```text
MulticosimError
├── ConfigurationError        invalid input, raised before anything starts
│   ├── MessageTypeError      a message of the wrong type for a node or topic
│   └── FormulaError          an STL formula that does not parse (names line and column)
├── DependencyMissingError    an optional dependency is not installed (names the extra)
├── PlacementUnavailableError a placement cannot run here (no engine, no cluster)
│   └── EngineUnavailableError  the Docker engine cannot be reached
├── NodeError                 a running component misbehaved (carries name, exit code, log)
│   ├── NodeStartError        it did not become ready
│   │   └── ImageMissingError   its image is not present locally (never pulled)
│   ├── NodeTimeoutError      it did not answer in time
│   └── NodeCrashedError      it exited while it was needed
├── RemoteError               a component raised while handling a message
├── TransportError            a message could not be carried or decoded
├── SimulationStopped         the simulation was stopped (component side)
├── PhysicsDivergedError      MuJoCo's integration diverged under this configuration
├── RequirementViolation      a requirement does not hold (also an AssertionError) [1]
├── TraceError                a trace could not be written or read
├── ComponentCheckError       multicosim.testing.check_component found a fault [1]
└── CampaignInterrupted       Ctrl-C stopped a campaign (also a KeyboardInterrupt) [1]
```

[1] defined beside what it carries (``multicosim.search.requirements``,
``multicosim.local.check``, ``multicosim.search.campaign``); ``multicosim`` exports them all.

``Simulation.stop`` reports several failures at once as an ``ExceptionGroup`` of these.

Exceptions of the libraries underneath are turned into these in one place,
``translate``: ZeroMQ's into ``TransportError``, the Docker SDK's into
``EngineUnavailableError`` (or ``ImageMissingError``), rtamt's parse errors into
``FormulaError``. Each classic base (``ValueError``, ``ImportError``, ``AssertionError``,
``KeyboardInterrupt``) is kept where code outside multicosim relies on it.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = [
    "ConfigurationError",
    "DependencyMissingError",
    "EngineUnavailableError",
    "FormulaError",
    "ImageMissingError",
    "MessageTypeError",
    "MulticosimError",
    "NodeCrashedError",
    "NodeError",
    "NodeStartError",
    "NodeTimeoutError",
    "PhysicsDivergedError",
    "PlacementUnavailableError",
    "RemoteError",
    "SimulationStopped",
    "TraceError",
    "TransportError",
    "check_number",
    "translate",
]


class MulticosimError(Exception):
    """Root of every error raised by multicosim."""

    def __reduce__(self) -> tuple[Any, ...]:
        # Errors cross process boundaries (campaign workers, Ray): rebuilt from the message
        # and the attributes, since most constructors take other arguments than ``args``.
        return (_rebuild, (type(self), self.args), self.__dict__)


def _rebuild(cls: type[MulticosimError], args: tuple[Any, ...]) -> MulticosimError:
    error = cls.__new__(cls, *args)
    error.args = args
    return error


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


class FormulaError(ConfigurationError):
    """An STL formula that does not parse; ``line`` and ``column`` (0-based) locate the error."""

    def __init__(self, formula: str, line: int, column: int, reason: str) -> None:
        self.formula = formula
        self.line = line
        self.column = column
        self.reason = reason
        text = formula.splitlines()[line - 1] if formula.splitlines() else formula
        pointer = f"\n    {text}\n    {' ' * column}^"
        super().__init__(
            "formula",
            formula,
            f"an STL formula (rtamt syntax); at line {line}, column {column}: {reason}{pointer}",
        )


class DependencyMissingError(MulticosimError, ImportError):
    """An optional dependency is missing; the message names the extra to install."""

    def __init__(self, module: str, extra: str) -> None:
        self.module = module
        self.extra = extra
        super().__init__(
            f"{module!r} is required for this feature: pip install 'multicosim[{extra}]'"
        )


class PlacementUnavailableError(MulticosimError):
    """A placement cannot run components here: what it needs (a Docker engine, a Ray
    cluster, an image) is missing. The message says what in one line; ``detail`` says why
    and how to get it, where known."""

    def __init__(self, message: str, detail: str = "") -> None:
        super().__init__(message)
        self.detail = detail


class EngineUnavailableError(PlacementUnavailableError):
    """The Docker engine cannot be reached (not installed, not running or no permission)."""


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


class ImageMissingError(NodeStartError):
    """A component's image is not present locally (multicosim never pulls images)."""


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


class PhysicsDivergedError(MulticosimError):
    """MuJoCo's integration diverged (NaN or huge accelerations) under this configuration."""


class TraceError(MulticosimError):
    """A trace could not be written or read back."""


# -- the libraries' exceptions -----------------------------------------------------------------


def translate(exc: BaseException, *, name: str = "", formula: str = "") -> MulticosimError | None:
    """The multicosim error that a library's exception ``exc`` stands for, or None.

    ``name`` is the component or endpoint concerned, ``formula`` the STL
    formula being parsed (any exception rtamt raises while parsing it is a ``FormulaError``).
    The libraries are recognised by their exceptions' modules, so none is imported here.
    """
    if isinstance(exc, MulticosimError):
        return exc
    module = type(exc).__module__
    if formula:
        return _formula_error(formula, exc)
    if module.startswith("zmq"):
        return TransportError(f"{name + ': ' if name else ''}ZeroMQ: {exc}")
    if module.startswith("docker"):
        kinds = {cls.__name__ for cls in type(exc).__mro__}
        explanation = getattr(exc, "explanation", None) or exc
        if "APIError" not in kinds:  # no answer from the engine at all
            return EngineUnavailableError(f"the Docker engine cannot be used: {exc}")
        if name and "ImageNotFound" in kinds:
            return ImageMissingError(
                name, f"cannot start: its image is not present locally ({explanation})"
            )
        if name:
            return NodeStartError(name, f"could not be created: {explanation}")
    return None


def _formula_error(formula: str, exc: BaseException) -> FormulaError:
    # rtamt reports "RTAMT Exception: LINE:COLUMN: Syntax ERROR, ..." for parse errors, and
    # bare KeyErrors and the like for some malformed input.
    if type(exc).__name__ != "RTAMTException":
        return FormulaError(formula, 1, 0, f"{type(exc).__name__}: {exc}")
    message = str(exc).removeprefix("RTAMT Exception: ")
    head, _, rest = message.partition(": ")
    line_text, _, column_text = head.partition(":")
    if line_text.isdigit() and column_text.isdigit():
        reason = tidy_expected(rest.removeprefix("Syntax ERROR, ").strip())
        return FormulaError(formula, int(line_text), int(column_text), reason)
    return FormulaError(formula, 1, 0, message)


def tidy_expected(message: str) -> str:
    """An ANTLR message with only the readable tokens of its ``expecting {...}`` list."""
    head, sep, expected = message.partition(" expecting ")
    if not sep:
        return message
    names = [n.strip() for n in expected.strip("{}").split(",")]
    names = [n for n in names if n and n != "<INVALID>"]
    return f"{head}, expecting one of {', '.join(names)}" if names else head


def check_number(
    field: str, value: object, lo: float = -math.inf, hi: float = math.inf, *, open_lo: bool = False
) -> float:
    """Return ``value`` as a float if it is a finite number in range, else raise."""
    bracket = "(" if open_lo else "["
    allowed = f"a finite number in {bracket}{lo:g}, {hi:g}]"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigurationError(field, value, allowed)
    v = float(value)
    if not math.isfinite(v) or v < lo or v > hi or (open_lo and v == lo):
        raise ConfigurationError(field, value, allowed)
    return v


# Shown under the name users import them by: ``multicosim.NodeCrashedError`` in tracebacks and
# reports (and pickles, which find them there too).
for _name in __all__:
    _value = globals()[_name]
    if isinstance(_value, type):
        _value.__module__ = "multicosim"
del _name, _value
