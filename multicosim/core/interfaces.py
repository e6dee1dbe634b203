"""The paper's interfaces: Node, CommunicationNode, Component, Simulator, Simulation, NodeId.

They are structural (``typing.Protocol``): any class with the right methods is a component,
whether or not it inherits from anything here.
"""

from __future__ import annotations

import itertools
from typing import Generic, Protocol, TypeVar, final, runtime_checkable

from .errors import ConfigurationError

__all__ = [
    "CommunicationNode",
    "Component",
    "Composite",
    "Node",
    "NodeId",
    "RunsImages",
    "Simulation",
    "Simulator",
    "StartsSeveral",
]

MsgT_contra = TypeVar("MsgT_contra", contravariant=True)
ReplyT_co = TypeVar("ReplyT_co", covariant=True)
EnvT_contra = TypeVar("EnvT_contra", contravariant=True)
EnvT_co = TypeVar("EnvT_co", covariant=True)
NodeT = TypeVar("NodeT", bound="Node")
NodeT_co = TypeVar("NodeT_co", bound="Node", covariant=True)


@runtime_checkable
class Node(Protocol):
    """An executing element of a simulation."""

    def stop(self) -> None:
        """Shut the element down; calling it again does nothing."""
        ...


@runtime_checkable
class Composite(Node, Protocol):
    """A node made of other nodes (a firmware with its bridges, an attached container
    stack): a simulation finds every node of its run through ``parts``."""

    def parts(self) -> list[Node]:
        """The nodes it is made of, in start order."""
        ...


@runtime_checkable
class CommunicationNode(Node, Protocol[MsgT_contra, ReplyT_co]):
    """A node that can be talked to while it runs."""

    def send(self, msg: MsgT_contra) -> ReplyT_co:
        """Send ``msg`` to the running element and return its reply."""
        ...


class Component(Protocol[EnvT_contra, NodeT_co]):
    """All the configuration of one simulation element; ``start`` runs it."""

    def start(self, environment: EnvT_contra) -> NodeT_co:
        """Start the element in ``environment`` and return the node that manages it."""
        ...


@runtime_checkable
class RunsImages(Protocol):
    """A component that runs containers: its images are checked before anything starts, and
    only a simulator that runs containers takes it."""

    def required_images(self) -> tuple[str, ...]:
        """The images it needs locally (empty where it runs none)."""
        ...


@runtime_checkable
class StartsSeveral(Protocol):
    """A component that starts several named nodes (an attached container stack): each
    name is taken in its simulation as the component's own is."""

    def node_names(self) -> list[str]:
        """The names of the nodes it starts."""
        ...


_simulation_tokens = itertools.count(1)


def new_simulator_token() -> int:
    """A process-unique number that ties NodeIds to the simulator that issued them."""
    return next(_simulation_tokens)


@final
class NodeId(Generic[NodeT_co]):
    """Names one node of one simulation; ``Simulation.get`` turns it into the node.

    The type parameter is the node's type, so ``simulation.get(node_id)`` is typed.
    """

    __slots__ = ("index", "name", "owner")

    def __init__(self, owner: int, index: int, name: str) -> None:
        self.owner = owner
        self.index = index
        self.name = name

    def __repr__(self) -> str:
        return f"NodeId({self.name!r}, index={self.index})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, NodeId):
            return NotImplemented
        return (self.owner, self.index) == (other.owner, other.index)

    def __hash__(self) -> int:
        return hash((self.owner, self.index))

    def check_owner(self, owner: int) -> None:
        """Raise ConfigurationError unless this id was issued by simulator ``owner``."""
        if self.owner != owner:
            raise ConfigurationError(
                "node_id", self, "a NodeId returned by add() on this simulation's simulator"
            )


class Simulation(Protocol):
    """A started set of nodes; ``stop`` shuts them all down."""

    def get(self, node_id: NodeId[NodeT]) -> NodeT:
        """The node that ``node_id`` names."""
        ...

    def stop(self) -> None:
        """Stop every node (reverse start order); calling it again does nothing."""
        ...


class Simulator(Protocol[EnvT_co]):
    """A set of configured components; ``start`` runs them and returns a Simulation."""

    def add(self, component: Component[EnvT_co, NodeT]) -> NodeId[NodeT]:
        """Add ``component``; the returned id retrieves its node from the simulation."""
        ...

    def start(self) -> Simulation:
        """Create the execution environment, start every component, return the Simulation."""
        ...
