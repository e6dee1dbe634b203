"""Shared machinery of Simulation implementations: node lookup and orderly stopping."""

from __future__ import annotations

import logging
from collections.abc import Callable
from types import TracebackType
from typing import Any, TypeVar

from ..core.errors import ConfigurationError
from ..core.interfaces import Node, NodeId

__all__ = ["NodeSet", "add_start_observer", "started", "stop_all"]

log = logging.getLogger(__name__)

NodeT = TypeVar("NodeT", bound=Node)

_start_observers: list[Callable[[object], None]] = []


def add_start_observer(observer: Callable[[object], None]) -> Callable[[], None]:
    """Call ``observer`` with every simulation as it starts; return what removes it.

    A local simulation is announced before its components start, a scenario's (a
    ``ScenarioSimulation``) again once it wraps it: a trace that records what a search
    simulates (``multicosim.trace``) listens here.
    """
    _start_observers.append(observer)
    return lambda: _start_observers.remove(observer)


def started(simulation: object) -> None:
    """Announce ``simulation`` to the start observers."""
    for observer in list(_start_observers):
        observer(simulation)


def stop_all(steps: list[tuple[str, Callable[[], None]]], what: str) -> None:
    """Run every stop step in order, even after failures; raise them all as one group."""
    errors: list[Exception] = []
    for label, step in steps:
        try:
            step()
        except Exception as exc:
            exc.add_note(f"while stopping {label}")
            errors.append(exc)
        except BaseException as exc:
            # Ctrl-C during teardown: finish stopping the rest first, then re-raise.
            log.warning("interrupted while stopping %s; stopping the rest first", label)
            stop_all(steps[steps.index((label, step)) + 1 :], what)
            raise exc from None
    if errors:
        raise ExceptionGroup(f"{len(errors)} failure(s) while stopping {what}", errors)


class NodeSet:
    """The nodes of a simulation in start order, with ``get`` and idempotent ``stop``."""

    def __init__(self, owner: int, description: str) -> None:
        self._owner = owner
        self._description = description
        self._nodes: list[tuple[NodeId[Any], Node]] = []
        self._cleanups: list[tuple[str, Callable[[], None]]] = []
        self.stopped = False

    def _add_node(self, node_id: NodeId[Any], node: Node) -> None:
        self._nodes.append((node_id, node))

    def add_cleanup(self, label: str, cleanup: Callable[[], None]) -> None:
        """Run ``cleanup`` at stop, after the nodes started before it were registered."""
        self._cleanups.append((label, cleanup))

    def get(self, node_id: NodeId[NodeT]) -> NodeT:
        """The node that ``node_id`` names (it must come from this simulation's simulator)."""
        node_id.check_owner(self._owner)
        for nid, node in self._nodes:
            if nid == node_id:
                return node  # type: ignore[return-value]
        raise ConfigurationError("node_id", node_id, "the id of a node that was started")

    @property
    def nodes(self) -> list[Node]:
        """Every node, in start order."""
        return [node for _, node in self._nodes]

    def _stop_steps(self) -> list[tuple[str, Callable[[], None]]]:
        steps = [(f"component {nid.name!r}", node.stop) for nid, node in reversed(self._nodes)]
        return steps + list(reversed(self._cleanups))

    def stop(self) -> None:
        """Stop every node in reverse start order; failures are raised together afterwards."""
        if self.stopped:
            return
        self.stopped = True
        stop_all(self._stop_steps(), self._description)

    def __enter__(self: _Self) -> _Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()


_Self = TypeVar("_Self", bound=NodeSet)
