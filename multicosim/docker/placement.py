"""The ``docker`` placement: every component a container on its simulation's network.

Participants and firmware run from the runtime image (``multicosim images build``) unless
their program names another; external programs (SITL builds) from their own image, which a
vehicle package may build on first use. The simulation's clock and its bridges stay in this
process: containers reach them at the network's gateway.

The Docker SDK is imported when a component starts (or the placement is prepared), not
when the placement is looked up, so that a run without the docker extra can still name it
and be told what is missing.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from ..core.errors import (
    ConfigurationError,
    EngineUnavailableError,
    MulticosimError,
    PlacementUnavailableError,
)
from ..core.interfaces import CommunicationNode, Component, Node
from ..local import LocalEnvironment, participant_command
from ..local.waits import DEFAULT_STEP_TIMEOUT
from ..placement import Endpoint, FirmwareProgram, ParticipantProgram, ProgramSpec
from ._images import RUNTIME_IMAGE

if TYPE_CHECKING:
    from ._simulator import ContainerSimulator
    from .environment import ContainerEnvironment
    from .node import ContainerNode

__all__ = ["FIRMWARE_PORT", "ContainerParticipant", "ContainerProgram", "Docker"]

log = logging.getLogger(__name__)

FIRMWARE_PORT = 5556
"""The container port a firmware serves on (published on a random loopback host port)."""


def _container_environment(environment: LocalEnvironment, name: str) -> ContainerEnvironment:
    from .environment import ContainerEnvironment

    if not isinstance(environment, ContainerEnvironment):
        raise ConfigurationError(
            "placement",
            "docker",
            f"a simulator of the docker placement for {name!r} (containers need its network); "
            "this simulator runs none",
        )
    return environment


class ContainerParticipant:
    """Participant ``program`` as a container (``multicosim participant`` in its image)."""

    def __init__(self, program: ParticipantProgram) -> None:
        self.program = program
        self.name = program.name

    def required_images(self) -> tuple[str, ...]:
        """The runtime image, unless the program brings its own (built on start, or named)."""
        program = self.program
        return program.images if program.image is not None else (RUNTIME_IMAGE, *program.images)

    def start(self, environment: LocalEnvironment) -> ContainerNode:
        """Start the container; return once its program has joined the simulation."""
        from ._component import ContainerComponent

        program = self.program
        container_env = _container_environment(environment, program.name)
        image, config = (
            program.image() if program.image is not None else (RUNTIME_IMAGE, program.config)
        )
        return ContainerComponent(
            image,
            participant_command(program.factory, config),
            name=program.name,
            start_timeout=program.start_timeout,
            mounts=program.mounts,
        ).start(container_env)


class ContainerProgram:
    """External program ``spec`` in a container of its image, on the simulation's network."""

    def __init__(self, spec: ProgramSpec) -> None:
        if spec.image is None or spec.image_command is None:
            raise ConfigurationError(
                "image",
                spec.image,
                f"an image (and its command) that runs {spec.name!r} in a container",
            )
        self.spec = spec
        self.name = spec.name

    def required_images(self) -> tuple[str, ...]:
        """Its image, unless it is built on start."""
        return (self.spec.image,) if isinstance(self.spec.image, str) else ()

    def start(self, environment: LocalEnvironment) -> ContainerNode:
        """Start the container (its program joins no simulation: it talks to bridges)."""
        from ._component import ContainerComponent

        spec = self.spec
        assert spec.image_command is not None
        container_env = _container_environment(environment, spec.name)
        image = spec.image() if callable(spec.image) else spec.image
        assert image is not None
        node = ContainerComponent(
            image,
            list(spec.image_command),
            name=spec.name,
            ready="started",
            stop_timeout=spec.stop_timeout,
        ).start(container_env)
        if spec.image_workdir is not None:
            node.workdir = spec.image_workdir
        return node


class Docker:
    """Components as containers of the Docker engine, one network per simulation."""

    name = "docker"
    in_process = False

    def simulator(
        self,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | None = None,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> ContainerSimulator:
        """A ContainerSimulator (its network is created on start)."""
        from ._simulator import ContainerSimulator

        return ContainerSimulator(
            seed=seed, realtime=realtime, run_dir=run_dir, step_timeout=step_timeout
        )

    def participant(self, program: ParticipantProgram) -> ContainerParticipant:
        """The participant as a container of the runtime image (or the program's own)."""
        return ContainerParticipant(program)

    def firmware(self, program: FirmwareProgram) -> Component[Any, CommunicationNode[Any, Any]]:
        """The firmware served in a container, reached through a published loopback port."""
        from ._firmware import ContainerFirmwareComponent

        component: ContainerFirmwareComponent[Any, Any] = ContainerFirmwareComponent(
            image=program.image or RUNTIME_IMAGE,
            command=[
                *("multicosim", "serve", program.factory),
                *("--host", "0.0.0.0", "--port", "{port}"),
            ],
            port=FIRMWARE_PORT,
            msgtype=program.msgtype,
            replytype=program.replytype,
            name=program.name,
            timeout=program.timeout,
            start_timeout=program.start_timeout,
        )
        return component

    def program(self, spec: ProgramSpec) -> Component[Any, Node]:
        """The external program in a container of ``spec.image``."""
        return ContainerProgram(spec)

    def endpoint(self, environment: LocalEnvironment) -> Endpoint:
        """The network's gateway: the container has the network (and its ports) to itself."""
        container_env = _container_environment(environment, "an external program")
        return Endpoint(host=container_env.gateway, private=True)

    def prepare(self) -> None:
        """A running engine and the runtime image, rebuilt if its source changed (in a
        checkout; an installed package needs it present).

        EngineUnavailableError without an engine (or the Docker SDK);
        PlacementUnavailableError where the image can be neither built nor found.
        """
        try:
            from .engine import ImageNotFound, client, engine_available, engine_url
        except ImportError as exc:  # the docker extra is missing (DependencyMissingError)
            raise EngineUnavailableError(
                "no Docker SDK (pip install 'multicosim[docker]')", str(exc)
            ) from exc
        reason = engine_available()  # what is wrong: nothing answers, or a permission
        if reason is not None:
            raise EngineUnavailableError(f"no Docker engine at {engine_url()}", reason)
        from ._images import build

        try:
            build()
        except MulticosimError as exc:
            try:
                client().api.inspect_image(RUNTIME_IMAGE)
            except ImageNotFound:
                raise PlacementUnavailableError(
                    f"{RUNTIME_IMAGE} could not be built",
                    f"{exc}; build it with `multicosim images build` in a checkout of multicosim",
                ) from exc
            log.warning("using %s as it is: %s", RUNTIME_IMAGE, exc)

    def __repr__(self) -> str:
        return "<placement 'docker'>"
