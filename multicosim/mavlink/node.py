"""The firmware node a ground station flies: ``send(Configuration) -> MissionResult``.

PX4's and ArduPilot's scenarios both give ``MissionNode`` as their firmware: the ground
station (``gcs``) in this process, the autopilot wherever it runs.
"""

from __future__ import annotations

from typing import Any

from ..core.errors import MessageTypeError, MulticosimError
from ..core.interfaces import Node
from ..core.messages import type_name
from ..local import (
    InProcessFirmwareNode,
)
from .mission import Configuration, MissionResult

__all__ = ["MissionNode"]


class MissionNode:
    """A firmware node flown by a ground station: ``send(Configuration) -> MissionResult``.

    ``send`` acts as the ground station (the reference's MAVSDK script): it validates the
    configuration (``check``), sets parameters, uploads the mission, arms, starts it and
    records the trajectory until the mission ends or its time limit passes. ``component``
    is what started it (its ``world`` has home, its ``geofence`` bounds missions);
    ``autopilot_node`` the autopilot's node (in this process, a process, a container, or
    real firmware with its bridges); ``ground_station`` the ground station's.
    """

    def __init__(
        self,
        name: str,
        gcs: InProcessFirmwareNode[Configuration, MissionResult],
        autopilot: Node,
        component: Any,
    ) -> None:
        self.name = name
        self.ground_station = gcs
        self.autopilot_node = autopilot
        self.component = component
        self._stopped = False

    def parts(self) -> list[Node]:
        """The autopilot's node, then the ground station's."""
        return [self.autopilot_node, self.ground_station]

    def check(self, msg: Configuration) -> None:
        """Raise ConfigurationError if ``msg`` cannot be flown (a waypoint outside the fence)."""
        msg.check_geofence(self.component.world.home, self.component.geofence)

    def send(self, msg: Configuration, *, timeout: float | None = None) -> MissionResult:
        """Fly the mission in ``msg`` and return its result.

        ``timeout``: the wall seconds the simulated clock may stand still before the flight
        is given up (the ground station's own; liveness, not a bound on the mission, whose
        limit is ``msg.time_limit`` in simulated seconds).
        """
        if self._stopped:
            raise MulticosimError(f"component {self.name!r} is stopped")
        if not isinstance(msg, Configuration):
            raise MessageTypeError(
                "msg", msg, f"a {type_name(Configuration)} (the message type of {self.name!r})"
            )
        self.check(msg)
        return self.ground_station.send(msg, timeout=timeout)

    def stop(self) -> None:
        """Stop the ground station and the autopilot; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        from ..local.simulation import stop_all

        stop_all(
            [(f"{self.name}.gcs", self.ground_station.stop), (self.name, self.autopilot_node.stop)],
            f"component {self.name!r}",
        )
