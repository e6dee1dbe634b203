"""The world of a fleet at medium and high fidelity: one MuJoCo world holding every quadrotor.

``python -m multicosim participant multicosim.fleet.world:world --config JSON`` runs it as a
process (or a container): the same program in every placement.
"""

from __future__ import annotations

import msgspec

from ..mavlink.hil import Wire
from ..physics.config import WorldConfig
from ..physics.fleet import Pose
from ..physics.world import World
from ..quadrotor.vehicle import QuadrotorVehicle

__all__ = ["FleetWorldSpec", "world"]


class FleetWorldSpec(msgspec.Struct, frozen=True, kw_only=True):
    """The fleet's world: its configuration, each quadrotor's start by name, and the wire its
    sensors travel on to its autopilot (native Structs, or MAVLink frames), by name."""

    world: WorldConfig
    vehicles: dict[str, Pose]
    wires: dict[str, Wire]


def world(spec: FleetWorldSpec) -> World:
    """The fleet's world participant (factory of ``multicosim participant``)."""
    return World(
        spec.world,
        {
            name: (QuadrotorVehicle(wire=spec.wires[name]), pose)
            for name, pose in spec.vehicles.items()
        },
    )
