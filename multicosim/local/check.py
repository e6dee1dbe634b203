"""A conformance checker for users' own components, as Gymnasium's ``check_env`` is for envs.

[`check_component`][multicosim.local.check.check_component] runs one participant or firmware the
ways multicosim runs it, in-process and as a local process, and checks what every component must do:
run, give the same messages twice for one seed and the same in-process as in a process, stop
idempotently, and leave no thread, process or run directory behind.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, cast

from ..core.clock import Delivery
from ..core.errors import ConfigurationError, MulticosimError
from ..core.interfaces import Component
from ..core.messages import encode
from ..runtime.serve import Firmware
from . import (
    InProcessComponent,
    InProcessFirmwareComponent,
    ProcessComponent,
    ProcessFirmwareComponent,
    ProcessSimulation,
    ProcessSimulator,
    participant_command,
)

__all__ = ["Check", "ComponentReport", "check_component"]

# multicosim's own threads that serve the whole process once started (the in-process call
# deadlines): not something a component left behind.
_SERVICE_THREADS = frozenset({"multicosim-deadlines"})

# What one run gave: every message routed (topic, time, MessagePack bytes) and the reply.
_Run = tuple[list[tuple[str, int, bytes]], bytes | None]


@dataclasses.dataclass(frozen=True)
class Check:
    """One check of [`check_component`][multicosim.local.check.check_component]: its ``name``,
    whether it ``passed``, and why not."""

    name: str
    passed: bool
    detail: str = ""


@dataclasses.dataclass(frozen=True)
class ComponentReport:
    """What [`check_component`][multicosim.local.check.check_component] found; ``str(report)`` lists
    every check."""

    target: str
    checks: tuple[Check, ...]

    @property
    def passed(self) -> bool:
        """Whether every check passed."""
        return all(check.passed for check in self.checks)

    @property
    def failures(self) -> tuple[Check, ...]:
        """The checks that failed."""
        return tuple(check for check in self.checks if not check.passed)

    def __str__(self) -> str:
        lines = [f"check_component({self.target}):"]
        for check in self.checks:
            lines.append(f"  {'ok  ' if check.passed else 'FAIL'} {check.name}")
            if check.detail:
                lines.extend(f"       {line}" for line in check.detail.splitlines())
        return "\n".join(lines)


class ComponentCheckError(MulticosimError):
    """``check_component`` found a fault; ``report`` lists every check and what failed."""

    def __init__(self, report: ComponentReport) -> None:
        self.report = report
        super().__init__(str(report))


# Shown as ``multicosim.ComponentCheckError``, as every error is (see multicosim.core.errors).
ComponentCheckError.__module__ = "multicosim"


def check_component(
    target: str | Callable[..., Any] | Component[Any, Any],
    *,
    message: object = None,
    config: object = None,
    duration: float = 1.0,
    seed: int = 0,
    beside: Callable[[], Sequence[Component[Any, Any]]] | None = None,
    name: str = "checked",
    raise_on_failure: bool = True,
) -> ComponentReport:
    """Run a participant or firmware in-process and as a process; check that it behaves.

    ``target`` is the component as ``"module:attribute"`` (how a process finds it), or the
    object itself (a ``@multicosim.firmware`` function, or a participant class or factory,
    importable under its module and name). A participant is stepped for ``duration``
    simulated seconds, built as ``factory(config)`` (``config`` goes to a process as JSON)
    or ``factory()``; a firmware is sent ``message``. A component object of one's own (with
    ``start(environment)``, such as a ``ProcessComponent``) is run as it is, twice.
    ``beside`` makes the components it needs around it (a world for a controller), fresh for
    every run.

    The checks: it runs in-process; two in-process runs with ``seed`` give the same messages
    and reply; it runs as a process; the process gives what the in-process run gave; stopping
    twice is harmless; no thread, child process or run directory is left behind. Returns the
    report; raises ComponentCheckError carrying it if a check failed (unless
    ``raise_on_failure`` is false).
    """
    if _is_component(target):
        return _check_as_given(target, message, duration, seed, beside, raise_on_failure)
    reference, obj, problem = _resolve(cast("str | Callable[..., Any]", target))
    is_firmware = isinstance(obj, Firmware)
    if obj is not None and not is_firmware and not callable(obj):
        raise ConfigurationError(
            "target", target, "a @multicosim.firmware function or a participant factory"
        )
    if is_firmware and message is None:
        raise ConfigurationError("message", message, "a message to send to the firmware")
    if not is_firmware and (isinstance(duration, bool) or not 0 < duration <= 3600):
        raise ConfigurationError("duration", duration, "simulated seconds in (0, 3600]")
    plan = _Plan(beside, seed, message, duration, is_firmware)
    checks: list[Check] = []
    runs: dict[str, _Run] = {}

    def attempt(label: str, make: Callable[[], Component[Any, Any]]) -> None:
        try:
            runs[label], extra = plan.run(make, label)
        except Exception as exc:  # the report says what went wrong, in any component
            checks.append(Check(f"runs {label}", False, f"{type(exc).__name__}: {exc}"))
            return
        checks.append(Check(f"runs {label}", True))
        checks.extend(extra)

    if obj is None:
        checks.append(Check("runs in-process", False, problem))
    else:
        attempt("in-process", lambda: _in_process(obj, config, name))
        if "in-process" in runs:
            again = plan.rerun(lambda: _in_process(obj, config, name))
            checks.append(
                _compare(
                    f"deterministic for seed {seed}",
                    runs["in-process"],
                    again,
                    "a second in-process run",
                )
            )
    if reference is None:
        checks.append(Check("runs as a process", False, problem))
    else:
        firmware_type = obj.msgtype if isinstance(obj, Firmware) else None
        attempt(
            "as a process",
            lambda: _as_process(reference, config, name, is_firmware, firmware_type),
        )
    if "in-process" in runs and "as a process" in runs:
        checks.append(
            _compare(
                "the same in-process and as a process",
                runs["in-process"],
                runs["as a process"],
                "the process",
            )
        )
    report = ComponentReport(reference or repr(target), tuple(checks))
    if raise_on_failure and not report.passed:
        raise ComponentCheckError(report)
    return report


def _is_component(target: object) -> bool:
    return (
        not isinstance(target, str | type | Firmware)
        and callable(getattr(target, "start", None))
        and not callable(target)
    )


def _check_as_given(
    component: Any,
    message: object,
    duration: float,
    seed: int,
    beside: Callable[[], Sequence[Component[Any, Any]]] | None,
    raise_on_failure: bool,
) -> ComponentReport:
    # A node that answers messages is sent one.
    plan = _Plan(beside, seed, message, duration, is_firmware=message is not None)
    checks: list[Check] = []
    try:
        first, extra = plan.run(lambda: component)
    except Exception as exc:  # the report says what went wrong
        checks.append(Check("runs", False, f"{type(exc).__name__}: {exc}"))
    else:
        checks.append(Check("runs", True))
        checks.extend(extra)
        again = plan.rerun(lambda: component)
        checks.append(_compare(f"deterministic for seed {seed}", first, again, "a second run"))
    report = ComponentReport(repr(component), tuple(checks))
    if raise_on_failure and not report.passed:
        raise ComponentCheckError(report)
    return report


# -- the runs -------------------------------------------------------------------------------


def _resolve(target: str | Callable[..., Any]) -> tuple[str | None, Any, str]:
    """(``module:attribute`` or None, the object or None, what is wrong with what is None)."""
    from ..runtime.serve import load_target

    if isinstance(target, str):
        try:
            return target, load_target(target), ""
        except (ImportError, AttributeError, ValueError) as exc:
            return None, None, f"cannot import {target!r}: {type(exc).__name__}: {exc}"
    handler = target.handler if isinstance(target, Firmware) else target
    module = getattr(handler, "__module__", None)
    qualname = getattr(handler, "__qualname__", "")
    reference = f"{module}:{qualname}"
    try:
        found = load_target(reference)
    except (ImportError, AttributeError, ValueError):
        found = None
    if module is None or "<" in qualname or found is not target:
        return (
            None,
            target,
            (
                f"{target!r} cannot be found by name as {reference!r}: a process imports its "
                "component by module and name, so define it at the top level of a module"
            ),
        )
    return reference, target, ""


def _in_process(obj: Any, config: object, name: str) -> Component[Any, Any]:
    if isinstance(obj, Firmware):
        return InProcessFirmwareComponent(obj, name=name)
    factory = obj if config is None else (lambda: obj(config))
    return InProcessComponent(factory, name=name)


def _as_process(
    reference: str, config: object, name: str, is_firmware: bool, msgtype: Any
) -> Component[Any, Any]:
    if is_firmware:
        command = [sys.executable, "-m", "multicosim", "serve", reference, "--port", "{port}"]
        return ProcessFirmwareComponent(command, msgtype=msgtype, name=name)
    if config is None:
        command = [sys.executable, "-m", "multicosim", "participant", reference]
    else:
        command = [sys.executable, "-m", *participant_command(reference, config)]
    return ProcessComponent(command, name=name)


@dataclasses.dataclass(frozen=True)
class _Plan:
    """How each run goes: what runs beside, the seed, what it is sent or how long it runs."""

    beside: Callable[[], Sequence[Component[Any, Any]]] | None
    seed: int
    message: object
    duration: float
    is_firmware: bool

    def run(
        self, make: Callable[[], Component[Any, Any]], label: str = ""
    ) -> tuple[_Run, list[Check]]:
        """One run in a fresh simulation; the checks of stopping it and of what it left."""
        threads = set(threading.enumerate())
        children = _children()
        simulator = ProcessSimulator(seed=self.seed)
        for component in self.beside() if self.beside is not None else ():
            simulator.add(component)
        node_id = simulator.add(make())
        messages: list[tuple[str, int, bytes]] = []
        reply: bytes | None = None
        simulation: ProcessSimulation = simulator.start()
        run_dir = simulation.run_dir
        try:
            from ..core.clock import find_scheduler

            def tap(delivery: Delivery) -> None:
                messages.append((delivery.topic, delivery.time_ns, delivery.data))

            find_scheduler(simulation).taps.append(tap)
            node = simulation.get(node_id)
            if self.is_firmware:
                reply = encode(node.send(self.message))
            else:
                simulation.advance(self.duration)
        except BaseException:
            simulation.stop()
            raise
        where = f" ({label})" if label else ""
        checks = [_stops_twice(simulation, node, where)]
        checks.append(_left_behind(threads, children, run_dir, where))
        return (messages, reply), checks

    def rerun(self, make: Callable[[], Component[Any, Any]]) -> _Run | Exception:
        """What a run gave, or what it raised (reported as a difference from the first)."""
        try:
            return self.run(make)[0]
        except Exception as exc:  # the comparison reports it
            return exc


def _stops_twice(simulation: ProcessSimulation, node: Any, where: str) -> Check:
    problems: list[str] = []
    steps = [("the node", node.stop), ("the simulation", simulation.stop)]
    for what, stop in steps + steps:  # each once, then each again
        try:
            stop()
        except Exception as exc:  # any exception is the finding; the other stops still run
            problems.append(f"stopping {what} raised {type(exc).__name__}: {exc}")
    return Check(f"stops idempotently{where}", not problems, "\n".join(problems))


def _left_behind(
    threads: set[threading.Thread], children: set[int], run_dir: Path, where: str
) -> Check:
    left: list[str] = []
    for thread in set(threading.enumerate()) - threads:
        if thread.name in _SERVICE_THREADS:
            continue
        thread.join(timeout=2.0)  # a thread on its way out gets a moment to finish
        if thread.is_alive():
            left.append(f"thread {thread.name!r} still runs")
    left.extend(f"process {pid} ({_command(pid)}) still runs" for pid in _children() - children)
    if run_dir.exists():
        left.append(f"run directory {run_dir} still exists")
    return Check(f"leaves nothing behind{where}", not left, "\n".join(left))


def _compare(name: str, first: _Run, second: _Run | Exception, other: str) -> Check:
    if isinstance(second, Exception):
        return Check(name, False, f"{other} raised {type(second).__name__}: {second}")
    (messages, reply), (again, reply_again) = first, second
    for index, (a, b) in enumerate(zip(messages, again, strict=False)):
        if a != b:
            return Check(
                name,
                False,
                f"message {index} differs: {a[0]!r} at t={a[1] / 1e9:g} s, "
                f"{other} gave {b[0]!r} at t={b[1] / 1e9:g} s"
                + (" with other content" if a[:2] == b[:2] else ""),
            )
    if len(messages) != len(again):
        return Check(name, False, f"{len(messages)} messages, {other} gave {len(again)}")
    if reply != reply_again:
        return Check(name, False, f"the reply differs from what {other} replied")
    return Check(name, True)


def _children() -> set[int]:
    """The live child processes of this process (Linux: from /proc)."""
    me = os.getpid()
    found: set[int] = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[1]) == me and fields[0] != "Z":
            found.add(int(entry.name))
    return found


def _command(pid: int) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return "?"
    return raw.replace(b"\0", b" ").decode(errors="replace").strip()
