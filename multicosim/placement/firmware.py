"""Real firmware (SITL builds of PX4, ArduPilot, ...) beside a simulation, wherever it runs.

One launcher for every firmware family: ``launch`` asks the placement where the program
reaches this process ([`Endpoint`][multicosim.placement.protocol.Endpoint]), has the family claim
its instance and ports there, start its bridges in this process (they step on the simulation's
clock), describe its program, and tell when it is ready; the placement runs the program (a local
process, a container). What was started is one ``FirmwareNodes``, stopped in reverse
start order; a launch that fails stops what it had started before its error propagates.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from ..core.errors import ConfigurationError, NodeStartError
from ..core.interfaces import Component, Node
from ..local.simulation import stop_all
from ..local.simulators import required_images
from ..local.waits import ending, mark_reported
from .protocol import Endpoint, Placement, ProgramSpec

if TYPE_CHECKING:
    from ..local import LocalEnvironment

__all__ = [
    "FirmwareLaunch",
    "FirmwareNodes",
    "ProgramNode",
    "check_first_instance",
    "launch",
    "param_value",
    "preflight_program",
    "udp_free",
]

log = logging.getLogger(__name__)

_POLL = 0.01  # s between looks at a starting firmware


@runtime_checkable
class ProgramNode(Node, Protocol):
    """A running external program: its liveness, output and files, wherever it runs."""

    name: str

    @property
    def pid(self) -> int | None:
        """Its process id on this machine (None where it has none here)."""
        ...

    def poll(self) -> int | None:
        """The exit code once it has exited, else None."""
        ...

    def log_tail(self, lines: int = 40) -> str:
        """The last lines of its output."""
        ...

    def files(self, path: str, suffix: str, into: Path) -> list[Path]:
        """Its files ending in ``suffix`` under ``path`` (relative to its working directory),
        on this machine: copied into ``into`` where they are elsewhere."""
        ...


class FirmwareLaunch(Protocol):
    """What a firmware family tells the launcher: its claim, bridges, program and readiness.

    The launcher calls, in order: ``claim`` (instance number and bound sockets at the
    endpoint), ``bridges`` (components started in this process), ``program`` (what the
    placement runs), ``started`` (the running program, to watch), then ``ready`` until it
    is true or ``start_timeout`` wall seconds pass (the firmware's own start-up, before the
    simulation's clock runs it).
    """

    name: str
    start_timeout: float
    waiting_for: str
    """What ``ready`` waits for, for the error: ``"connect to its simulator"``."""

    def claim(self, endpoint: Endpoint) -> int:
        """Claim an instance (its ports) at ``endpoint``; return its number."""
        ...

    def bridges(self, endpoint: Endpoint) -> list[tuple[str, Component[Any, Node]]]:
        """The bridges to start in this process, named, in order."""
        ...

    def program(self, endpoint: Endpoint, workdir: Path) -> ProgramSpec:
        """The firmware's program (``workdir``: its working directory on this machine)."""
        ...

    def started(self, program: ProgramNode, endpoint: Endpoint) -> None:
        """The program runs: watch it."""
        ...

    def ready(self) -> bool:
        """Whether the firmware has finished starting (polled)."""
        ...

    def release(self) -> None:
        """Close what ``claim`` holds that no bridge took over (called after a failure too)."""
        ...


class FirmwareNodes:
    """A firmware's program and its bridges: stopped as one, in reverse start order."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.nodes: list[tuple[str, Node]] = []
        self.program: ProgramNode | None = None
        self.workdir: Path | None = None
        """The firmware's working directory on this machine (where a local program runs)."""
        self.instance = 0
        self.bridges: dict[str, Node] = {}

    @property
    def pid(self) -> int | None:
        """The program's process id on this machine (None where it has none here)."""
        return self.program.pid if self.program is not None else None

    def add(self, name: str, node: Node) -> None:
        """Track ``node`` (stopped before those added earlier)."""
        self.nodes.append((name, node))

    def parts(self) -> list[Node]:
        """Every node it holds, in start order."""
        return [node for _, node in self.nodes]

    @contextlib.contextmanager
    def starting(self) -> Iterator[FirmwareNodes]:
        """Stop every part started so far if the start fails; the start's error propagates."""
        try:
            yield self
        except BaseException as exc:
            try:
                self.stop()
            except Exception as cleanup:  # the start error says what matters; keep this too
                exc.add_note(f"while stopping what had started: {cleanup!r}")
            raise

    def files(self, path: str, suffix: str, into: Path) -> list[Path]:
        """The program's files ending in ``suffix`` under ``path`` (see ProgramNode.files)."""
        return [] if self.program is None else self.program.files(path, suffix, into)

    def stop(self) -> None:
        """Stop every node; raise what failed, together."""
        nodes, self.nodes = self.nodes, []
        stop_all([(name, node.stop) for name, node in reversed(nodes)], f"component {self.name!r}")


def launch(
    firmware: FirmwareLaunch,
    placement: Placement,
    environment: LocalEnvironment,
    nodes: FirmwareNodes | None = None,
) -> FirmwareNodes:
    """Start ``firmware`` where ``placement`` puts programs, with its bridges here.

    Returns once the firmware is ready; it then waits, in lockstep, for the simulation's
    clock. Every part started is stopped again if a later one fails (NodeStartError, with
    the program's output, where it exits or is not ready within its start timeout).
    """
    group = nodes if nodes is not None else FirmwareNodes(firmware.name)
    endpoint = placement.endpoint(environment)
    with group.starting():
        try:
            group.instance = firmware.claim(endpoint)
            for name, component in firmware.bridges(endpoint):
                node = component.start(environment)
                group.add(name, node)
                group.bridges[name] = node
            group.workdir = environment.run_dir / f"{firmware.name}-firmware"
            component = placement.program(firmware.program(endpoint, group.workdir))
            program = component.start(environment)
        finally:
            firmware.release()
        if not isinstance(program, ProgramNode):
            raise ConfigurationError(
                "placement", placement.name, "a placement whose programs are ProgramNodes"
            )
        group.add(firmware.name, program)
        group.program = program
        firmware.started(program, endpoint)
        _wait_ready(firmware, program)
        log.info("%s: firmware instance %d is running", firmware.name, group.instance)
    return group


def preflight_program(
    placement: Placement,
    name: str,
    *,
    command: bool,
    image: str | Callable[[], str] | None,
    needs: str = "",
) -> tuple[str, ...]:
    """Check, before anything starts, that ``placement`` can run firmware ``name`` that has a
    command on this machine (``command``) or ``image``; return the images it needs there.

    ConfigurationError (naming ``needs``, what the firmware's configuration lacks) where
    the placement cannot run it.
    """
    # Only whether there is a command (an image) matters here, not which.
    spec = ProgramSpec(
        name=name,
        command=(name,) if command else None,
        image=image,
        image_command=(name,) if image is not None else None,
    )
    try:
        component = placement.program(spec)
    except ConfigurationError as exc:
        if not needs:
            raise
        raise ConfigurationError(
            "firmware", name, f"{needs} (the placement is {placement.name!r})"
        ) from exc
    return tuple(required_images(component))


def _wait_ready(firmware: FirmwareLaunch, program: ProgramNode) -> None:
    # Wall time: the firmware starts before the simulation's clock can run it.
    deadline = time.monotonic() + firmware.start_timeout
    while not firmware.ready():
        code = program.poll()
        if code is not None:
            mark_reported(program)  # this error says it; stopping the program need not again
            raise NodeStartError(
                firmware.name,
                f"{ending(program)} before it could {firmware.waiting_for}",
                exit_code=code,
                log_tail=program.log_tail(),
            )
        if time.monotonic() > deadline:
            raise NodeStartError(
                firmware.name,
                f"did not {firmware.waiting_for} within its start-up limit of "
                f"{firmware.start_timeout:g} s (wall clock)",
                log_tail=program.log_tail(),
            )
        time.sleep(_POLL)


# -- what firmware families share in claiming instances and writing parameters ----------------


def udp_free(host: str, port: int) -> bool:
    """Whether UDP ``port`` can be bound on ``host`` now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


def check_first_instance(first: object, most: int) -> None:
    """Raise ConfigurationError unless ``first`` is an instance number from 0 to ``most``."""
    if isinstance(first, bool) or not isinstance(first, int) or not 0 <= first <= most:
        raise ConfigurationError("first_instance", first, f"an instance number from 0 to {most}")


def param_value(value: float) -> str:
    """A parameter's value as a firmware's parameter file writes it (integers without ``.0``)."""
    return str(int(value)) if float(value).is_integer() and abs(value) < 2**31 else repr(value)
