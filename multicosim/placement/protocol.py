"""The placement protocol: how a simulator is made and a component started, wherever it runs.

A placement is one answer to "where does this component run?": in the simulation's own
process, as a local process, in a Docker container, on a Ray cluster. Scenarios describe
their components once, as programs (a participant's ``module:factory`` and configuration, a
firmware's ``module:firmware``, an external program such as a SITL build), and the
placement turns each description into a component of its kind. A scenario never asks which
placement it has; it asks the placement.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from ..core.interfaces import CommunicationNode, Component, Node
from ..local.waits import DEFAULT_SEND_TIMEOUT, DEFAULT_START_TIMEOUT, DEFAULT_STEP_TIMEOUT

if TYPE_CHECKING:
    from ..local import LocalEnvironment, LocalSimulatorBase
    from ..runtime.context import Participant

__all__ = [
    "Endpoint",
    "FirmwareProgram",
    "ParticipantProgram",
    "Placement",
    "ProgramSpec",
]


@dataclasses.dataclass(frozen=True)
class ParticipantProgram:
    """A participant as a program: ``factory`` (``module:callable``) applied to ``config``.

    ``config`` is a msgspec Struct (or None): it travels as JSON to a process or container,
    whose ``multicosim participant`` decodes it by the factory's annotation. ``build``
    makes the participant in this process where the factory's own result is not what should
    run there (default: the factory called with ``config``); ``local_config`` the
    configuration a program on this machine gets (default: ``config``); ``image`` the image
    and configuration a container runs (default: the runtime image and ``config``), and
    ``images`` the images it is known to need then (checked before a run starts).
    ``mounts`` maps directories (or files) of this machine to where a container sees them,
    read-only: what a program reads from the user's disk (models loaded from a path) reaches
    it there; placements that run programs on this machine need none.
    """

    factory: str
    config: Any
    name: str
    build: Callable[[LocalEnvironment], Participant] | None = None
    local_config: Callable[[LocalEnvironment], Any] | None = None
    image: Callable[[], tuple[str, Any]] | None = None
    images: tuple[str, ...] = ()
    start_timeout: float = DEFAULT_START_TIMEOUT
    mounts: Mapping[str, str] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class FirmwareProgram:
    """A firmware (``@multicosim.firmware``) as a program: ``factory`` names it as
    ``module:attribute``; it is reached with ``send(msgtype) -> replytype``."""

    factory: str
    name: str
    msgtype: type[Any] | None = None
    replytype: type[Any] | None = None
    image: str | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT
    start_timeout: float = DEFAULT_START_TIMEOUT


@dataclasses.dataclass(frozen=True)
class ProgramSpec:
    """An external program (a SITL build) as a component: on this machine, ``command`` run
    in ``cwd`` with ``env``; in a container, ``image_command`` run in ``image`` (a name, or
    what builds the image and returns its name, called only where a container runs it).

    ``image_workdir`` is its working directory in the container (where its files are).
    Either may be missing where the program cannot run so (a placement that needs the one
    missing says so, naming the field). It joins no simulation itself: it talks to bridges
    in this process (see [`Endpoint`][multicosim.placement.protocol.Endpoint]).
    """

    name: str
    command: Sequence[str] | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    cwd: str | None = None
    image: str | Callable[[], str] | None = None
    image_command: Sequence[str] | None = None
    image_workdir: str | None = None
    stop_timeout: float = 10.0


@dataclasses.dataclass(frozen=True)
class Endpoint:
    """Where an external program reaches the bridges of this process, and whether its ports
    are its own.

    ``host`` is the address the bridges listen on (loopback for programs on this machine;
    a container network's gateway for containers). ``private`` is True where the program
    has a network of its own (a container): it can use its firmware's first instance and
    usual ports; where it shares this machine's, instances are claimed.
    """

    host: str
    private: bool


@runtime_checkable
class Placement(Protocol):
    """Where components run: one implementation per place, registered by name.

    ``name`` is the name it is registered under (``--mcs-placement``, ``placement=``);
    ``in_process`` says whether its components share the simulation's process (payloads
    between them then need no encoding: the native wire).
    """

    name: str
    in_process: bool

    def simulator(
        self,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | None = None,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> LocalSimulatorBase[Any]:
        """A new, unstarted simulator whose environment runs this placement's components."""
        ...

    def participant(self, program: ParticipantProgram) -> Component[Any, Node]:
        """The component that runs participant ``program`` here."""
        ...

    def firmware(self, program: FirmwareProgram) -> Component[Any, CommunicationNode[Any, Any]]:
        """The component that runs firmware ``program`` here, reached by ``send``."""
        ...

    def program(self, spec: ProgramSpec) -> Component[Any, Node]:
        """The component that runs the external program ``spec`` here."""
        ...

    def endpoint(self, environment: LocalEnvironment) -> Endpoint:
        """Where a program placed here reaches this process's bridges in ``environment``."""
        ...

    def prepare(self) -> None:
        """Make ready what its components need before a run (an image, a connection).

        Raises PlacementUnavailableError, saying what is missing and how to get it, where
        this placement cannot run here.
        """
        ...
