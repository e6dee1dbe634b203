"""The placements of this machine: ``in-process`` (the simulation's own process) and
``process`` (a local process each), both on a
[`ProcessSimulator`][multicosim.local.ProcessSimulator].

A component's program is the same in both: a participant is built by its factory from its
configuration (here, or by ``python -m multicosim participant`` in its process), a firmware
is served by ``python -m multicosim serve``. An external program (a SITL build) runs as a
local process under either: it cannot share a Python process.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError
from ..core.interfaces import CommunicationNode, Component, Node
from ..local import (
    InProcessComponent,
    InProcessFirmwareComponent,
    InProcessNode,
    LocalEnvironment,
    ProcessComponent,
    ProcessFirmwareComponent,
    ProcessNode,
    ProcessSimulator,
    participant_command,
)
from ..local.waits import DEFAULT_STEP_TIMEOUT
from ..runtime.serve import Firmware, load_target
from .protocol import Endpoint, FirmwareProgram, ParticipantProgram, ProgramSpec

if TYPE_CHECKING:
    from ..runtime.context import Participant

__all__ = [
    "InProcess",
    "InProcessParticipant",
    "LocalProcess",
    "ProcessParticipant",
    "build_participant",
    "load_firmware",
    "local_program",
]

LOOPBACK = Endpoint(host="127.0.0.1", private=False)


def build_participant(program: ParticipantProgram, environment: LocalEnvironment) -> Participant:
    """Participant ``program`` built in this process, as its own process would build it."""
    if program.build is not None:
        return program.build(environment)
    factory = load_target(program.factory)
    participant: Participant = factory(program.config) if program.config is not None else factory()
    return participant


def load_firmware(program: FirmwareProgram) -> Firmware[Any, Any]:
    """The firmware object ``program.factory`` names."""
    firmware = load_target(program.factory)
    if not isinstance(firmware, Firmware):
        raise ConfigurationError(
            "factory", program.factory, "a firmware made with @multicosim.firmware"
        )
    return firmware


def local_program(spec: ProgramSpec) -> Component[LocalEnvironment, Node]:
    """External program ``spec`` as a local process (ConfigurationError without a command)."""
    if spec.command is None:
        raise ConfigurationError(
            "command", None, f"a command that runs {spec.name!r} on this machine"
        )
    return ProcessComponent(
        list(spec.command),
        name=spec.name,
        env=dict(spec.env),
        cwd=spec.cwd,
        ready="started",
        stop_timeout=spec.stop_timeout,
    )


@dataclasses.dataclass(frozen=True)
class InProcessParticipant:
    """Participant ``program`` built and stepped in the simulation's process."""

    program: ParticipantProgram

    @property
    def name(self) -> str:
        """The component's name."""
        return self.program.name

    def start(self, environment: LocalEnvironment) -> InProcessNode[Any]:
        """Build it (bounded by the program's start timeout) and schedule it."""
        program = self.program
        return InProcessComponent(
            lambda: build_participant(program, environment),
            program.name,
            start_timeout=program.start_timeout,
        ).start(environment)


@dataclasses.dataclass(frozen=True)
class ProcessParticipant:
    """Participant ``program`` as a local process (``multicosim participant``)."""

    program: ParticipantProgram

    @property
    def name(self) -> str:
        """The component's name."""
        return self.program.name

    def start(self, environment: LocalEnvironment) -> ProcessNode:
        """Start the process; return once it has joined the simulation."""
        program = self.program
        config = program.config
        if program.local_config is not None:
            config = program.local_config(environment)
        command = [sys.executable, "-m", *participant_command(program.factory, config)]
        return ProcessComponent(
            command, name=program.name, start_timeout=program.start_timeout
        ).start(environment)


class _OnThisMachine:
    """What both local placements share: the simulator, external programs, the endpoint."""

    name: str
    in_process: bool

    def simulator(
        self,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | None = None,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> ProcessSimulator:
        """A ProcessSimulator (components in this process and as local processes)."""
        return ProcessSimulator(
            seed=seed, realtime=realtime, run_dir=run_dir, step_timeout=step_timeout
        )

    def program(self, spec: ProgramSpec) -> Component[LocalEnvironment, Node]:
        """External program ``spec`` as a local process."""
        return local_program(spec)

    def endpoint(self, environment: LocalEnvironment) -> Endpoint:
        """Loopback, shared with every other program on this machine."""
        return LOOPBACK

    def prepare(self) -> None:
        """Nothing to prepare: this machine runs them."""

    def __repr__(self) -> str:
        return f"<placement {self.name!r}>"


class InProcess(_OnThisMachine):
    """Components in the simulation's own process: no sockets, no encoding (the fastest)."""

    name = "in-process"
    in_process = True

    def participant(self, program: ParticipantProgram) -> InProcessParticipant:
        """The participant built and stepped in this process."""
        return InProcessParticipant(program)

    def firmware(
        self, program: FirmwareProgram
    ) -> Component[LocalEnvironment, CommunicationNode[Any, Any]]:
        """The firmware called in the caller's thread."""
        return InProcessFirmwareComponent(
            load_firmware(program), name=program.name, timeout=program.timeout
        )


class LocalProcess(_OnThisMachine):
    """Each component a local process, stepped in lockstep over ZeroMQ."""

    name = "process"
    in_process = False

    def participant(self, program: ParticipantProgram) -> ProcessParticipant:
        """``python -m multicosim participant FACTORY --config JSON`` as a local process."""
        return ProcessParticipant(program)

    def firmware(
        self, program: FirmwareProgram
    ) -> Component[LocalEnvironment, CommunicationNode[Any, Any]]:
        """``python -m multicosim serve FACTORY`` as a local process, on a free port."""
        return ProcessFirmwareComponent(
            [sys.executable, "-m", "multicosim", "serve", program.factory, "--port", "{port}"],
            msgtype=program.msgtype,
            replytype=program.replytype,
            name=program.name,
            timeout=program.timeout,
            start_timeout=program.start_timeout,
        )
