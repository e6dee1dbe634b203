"""The world of a fleet at medium and high fidelity: one MuJoCo world holding every vehicle.

``python -m multicosim participant multicosim.fleet.world:world --config JSON`` runs it as a
process (or a container): the same program in every placement.
"""

from __future__ import annotations

from typing import Any, Literal

import msgspec

from ..mavlink.hil import Wire
from ..physics.config import WorldConfig
from ..physics.fleet import Pose
from ..physics.world import World

__all__ = ["BODIES", "Body", "FleetWorldSpec", "world"]

Body = Literal["quadrotor", "arducopter", "ardurover"]
BODIES: tuple[Body, ...] = ("quadrotor", "arducopter", "ardurover")
"""The vehicles a fleet's world holds: our quadrotor flown by PX4 (its sensors as PX4's
simulator interface), the quadrotor as ArduCopter's quad X, the rover as ArduRover's (both
through ArduPilot's JSON backend)."""


class FleetWorldSpec(msgspec.Struct, frozen=True, kw_only=True):
    """The fleet's world: its configuration, each vehicle's start and body by name, and, for
    a PX4 quadrotor, the wire its sensors travel on to its autopilot (native Structs, or
    MAVLink frames) and their period (its autopilot's), by name."""

    world: WorldConfig
    vehicles: dict[str, Pose]
    bodies: dict[str, Body] = {}
    wires: dict[str, Wire] = {}
    periods: dict[str, float] = {}


def _vehicle(body: Body, wire: Wire, period: float | None) -> Any:
    if body == "quadrotor":
        from ..quadrotor.vehicle import QuadrotorVehicle

        return QuadrotorVehicle(wire=wire, period=period)
    from ..ardupilot.vehicles import ArduCopterVehicle, ArduRoverVehicle

    return ArduCopterVehicle() if body == "arducopter" else ArduRoverVehicle()


def world(spec: FleetWorldSpec) -> World:
    """The fleet's world participant (factory of ``multicosim participant``)."""
    return World(
        spec.world,
        {
            name: (
                _vehicle(
                    spec.bodies.get(name, "quadrotor"),
                    spec.wires.get(name, "mavlink"),
                    spec.periods.get(name),
                ),
                pose,
            )
            for name, pose in spec.vehicles.items()
        },
    )
