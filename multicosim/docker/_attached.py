"""AttachedComponent: containers sharing one network stack (the paper's class)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Generic, Protocol, TypeVar

from ..core.errors import ConfigurationError
from ..core.interfaces import Node
from ._component import ContainerComponent
from ._firmware import ContainerFirmwareComponent, ContainerFirmwareNode
from .environment import ContainerEnvironment
from .node import ContainerNode

__all__ = ["AttachedComponent", "AttachedNode"]

HostT = TypeVar("HostT", bound=Node)
HostT_co = TypeVar("HostT_co", bound=Node, covariant=True)


class _HostComponent(Protocol[HostT_co]):
    """What AttachedComponent needs of its host: a container component with a name."""

    @property
    def name(self) -> str | None: ...
    @property
    def image(self) -> str: ...
    def start(self, environment: ContainerEnvironment) -> HostT_co: ...


class AttachedNode(Generic[HostT]):
    """A running AttachedComponent: the host's node and the attached containers' nodes."""

    def __init__(self, host: HostT, attached: Sequence[ContainerNode], name: str) -> None:
        self.host = host
        self.attached = tuple(attached)
        self.name = name
        self._stopped = False

    def parts(self) -> list[Node]:
        """The host's node, then the attached containers."""
        return [self.host, *self.attached]

    def stop(self) -> None:
        """Stop the attached containers (newest first), then the host."""
        if self._stopped:
            return
        self._stopped = True
        from ..local.simulation import stop_all

        steps = [(f"container {n.name!r}", n.stop) for n in reversed(self.attached)]
        stop_all([*steps, (f"host {self.name!r}", self.host.stop)], f"attached {self.name!r}")


def _container_of(node: Node) -> ContainerNode:
    if isinstance(node, ContainerFirmwareNode):
        return node.container
    assert isinstance(node, ContainerNode)
    return node


@dataclasses.dataclass(frozen=True)
class AttachedComponent(Generic[HostT]):
    """Containers sharing one network stack (the paper's AttachedComponent).

    Only ``host`` (a ContainerComponent or ContainerFirmwareComponent) joins the simulation's
    network and publishes ports; every ``attached`` container reuses its network stack, so
    they all talk to each other over localhost.
    """

    host: _HostComponent[HostT]
    attached: Sequence[ContainerComponent]
    name: str | None = None

    def __post_init__(self) -> None:
        host: object = self.host  # checked at run time: the annotation is not enforced
        if not isinstance(host, ContainerComponent | ContainerFirmwareComponent):
            raise ConfigurationError(
                "host", self.host, "a ContainerComponent or ContainerFirmwareComponent"
            )
        if isinstance(self.attached, ContainerComponent) or not all(
            isinstance(c, ContainerComponent) for c in self.attached
        ):
            raise ConfigurationError("attached", self.attached, "a sequence of ContainerComponent")
        for comp in self.attached:
            if comp.ports:
                raise ConfigurationError(
                    "ports", comp.ports, "no ports on attached containers (publish on the host)"
                )
        names = self.node_names()
        if len(set(names)) != len(names):
            raise ConfigurationError("name", names, "distinct names for host and attached")
        if self.name is None:
            object.__setattr__(self, "name", self.host.name)

    def node_names(self) -> list[str]:
        """The names under which the host and the attached containers join the simulation."""
        host_name = self.host.name
        assert host_name is not None
        return [host_name, *(str(c.name) for c in self.attached)]

    def required_images(self) -> tuple[str, ...]:
        """The images this component needs locally."""
        return tuple(dict.fromkeys([self.host.image, *(c.image for c in self.attached)]))

    def start(self, environment: ContainerEnvironment) -> AttachedNode[HostT]:
        """Start the host, then each attached container in its network stack."""
        assert self.name is not None
        host = self.host.start(environment)
        started: list[ContainerNode] = []
        try:
            for comp in self.attached:
                started.append(comp._start(environment, _container_of(host)))
        except BaseException as exc:
            node = AttachedNode(host, started, self.name)
            try:
                node.stop()
            except BaseExceptionGroup as group:
                exc.add_note(f"stopping the partial group also failed: {group!r}")
            raise
        return AttachedNode(host, started, self.name)
