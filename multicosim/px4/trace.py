"""The PX4 scenario's trace options: which of its topics carry HIL messages, for
``multicosim.mavlink.trace.mission_trace`` (the channels are described there).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..mavlink.hil import HilActuatorControls, HilGps, HilSensor, MavlinkPacket
from ..mavlink.trace import mission_trace
from ..quadrotor.topics import world_topics
from ..trace import (
    TraceOptions,
)

if TYPE_CHECKING:
    from ..core.geo import Home
    from ..physics.config import WorldConfig
    from .autopilot.firmware import AutopilotSpec

__all__ = ["trace_options"]


def trace_options(
    spec: AutopilotSpec,
    world: WorldConfig,
    name: str = "px4",
    *,
    member: bool = False,
    start: Home | None = None,
) -> TraceOptions:
    """Types, decoders and Foxglove channels of a PX4 simulation (see the module docstring);
    ``name`` is the vehicle's, which its channels are under (``member``, ``start``: as a
    fleet's vehicle, see ``mission_trace``)."""
    topics = world_topics(world)
    mavlink_wire = spec.wire == "mavlink"
    hil = {
        topics.imu: HilSensor,
        topics.mag: HilSensor,
        topics.baro: HilSensor,
        topics.gps: HilGps,
        topics.actuators: HilActuatorControls,
        spec.topics.imu: HilSensor,
        spec.topics.mag: HilSensor,
        spec.topics.baro: HilSensor,
        spec.topics.gps: HilGps,
    }
    types: dict[str, Any] = {
        topic: MavlinkPacket if mavlink_wire else tp for topic, tp in hil.items()
    }
    return mission_trace(
        vehicle=name,
        uplink=spec.uplink,
        downlink=spec.downlink,
        truth=topics.truth,
        home=world.home,
        obstacles=world.obstacles,
        types=types,
        links=(spec.uplink, spec.downlink, *(sorted(hil) if mavlink_wire else ())),
        member=member,
        start=start,
    )
