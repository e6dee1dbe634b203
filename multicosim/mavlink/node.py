"""The firmware node a ground station flies: ``send(Configuration) -> MissionResult``.

PX4's and ArduPilot's scenarios both give :class:`MissionNode` as their firmware: the ground
station (:mod:`.gcs`) in this process, the autopilot wherever it runs.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any, cast

from ..core.errors import MessageTypeError, MulticosimError
from ..core.interfaces import Node
from ..core.messages import type_name
from ..local import (
    InProcessFirmwareNode,
)
from .mission import Configuration, MissionResult

if TYPE_CHECKING:
    from ..docker import ContainerNode

__all__ = ["MissionNode"]


class MissionNode:
    """A firmware node flown by a ground station: ``send(Configuration) -> MissionResult``.

    ``send`` acts as the ground station (the reference's MAVSDK script): it validates the
    configuration (``check``), sets parameters, uploads the mission, arms, starts it and
    records the trajectory until the mission ends or its time limit passes. ``component``
    is what started it (its ``world`` has home, its ``geofence`` bounds missions).
    """

    def __init__(
        self,
        name: str,
        gcs: InProcessFirmwareNode[Configuration, MissionResult],
        autopilot: Node,
        component: Any,
    ) -> None:
        self.name = name
        self._gcs = gcs
        self._autopilot = autopilot
        self._component = component
        self._stopped = False

    @property
    def container(self) -> ContainerNode | None:
        """The autopilot's container node when it runs in one (the docker backend)."""
        # Also how a ContainerSimulation finds it, to signal it at stop with the others.
        # Without the docker backend loaded there is no container (and no SDK to import).
        docker_node = sys.modules.get("multicosim.docker.node")
        # Real firmware's nodes keep its process or container as ``process``.
        node = getattr(self._autopilot, "process", self._autopilot)
        if docker_node is not None and isinstance(node, docker_node.ContainerNode):
            return cast("ContainerNode", node)
        return None

    def check(self, msg: Configuration) -> None:
        """Raise ConfigurationError if ``msg`` cannot be flown (a waypoint outside the fence)."""
        msg.check_geofence(self._component.world.home, self._component.geofence)

    def send(self, msg: Configuration) -> MissionResult:
        """Fly the mission in ``msg`` and return its result."""
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        if not isinstance(msg, Configuration):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(Configuration)} (the message type of {self.name!r})"
            )
        self.check(msg)
        return self._gcs.send(msg)

    def stop(self) -> None:
        """Stop the ground station and the autopilot; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        from ..local.simulation import stop_all

        stop_all(
            [(f"{self.name}.gcs", self._gcs.stop), (self.name, self._autopilot.stop)],
            f"component {self.name!r}",
        )
