"""The base of scenario simulations (rover, PX4): a running simulation with named nodes."""

from __future__ import annotations

from pathlib import Path
from typing import Self, TypeVar

from ..core.interfaces import Node, NodeId
from .simulation import started
from .simulators import ProcessSimulation

__all__ = ["ScenarioSimulation"]

NodeT = TypeVar("NodeT", bound=Node)


class ScenarioSimulation:
    """Base of scenario simulations (rover, PX4): a running simulation with named nodes.

    Scenarios add their own attributes (``controller``, ``firmware``, ``world``); the rest
    (clock, seed, lookup, logs, stopping) is the wrapped simulation's.
    """

    def __init__(self, simulation: ProcessSimulation) -> None:
        self.simulation = simulation
        started(self)

    @property
    def time(self) -> float:
        """Current simulated time (s)."""
        return self.simulation.time

    @property
    def seed(self) -> int:
        """The simulation's seed."""
        return self.simulation.seed

    def get(self, node_id: NodeId[NodeT]) -> NodeT:
        """The node ``node_id`` names (ids come from the scenario simulator's ``add``)."""
        return self.simulation.get(node_id)

    def advance(self, duration: float) -> None:
        """Run the world for ``duration`` simulated seconds without a mission."""
        self.simulation.advance(duration)

    def logs(self) -> dict[str, Path]:
        """Log files of the components that run as processes or containers."""
        return self.simulation.logs()

    def stop(self) -> None:
        """Stop every node; idempotent."""
        self.simulation.stop()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
