"""What a trace of the PX4 scenario shows, in channels Foxglove understands.

* The MAVLink links between ground station and autopilot (``px4/mavlink/up`` and ``down``),
  and the HIL frames between world and autopilot where they travel as MAVLink, are decoded
  into one channel per message type (``px4/mavlink/down/ATTITUDE``, ...), each with a JSON
  schema generated from pymavlink's message definitions. The links also go to a ``.tlog``.
* ``px4/log``: the autopilot's STATUSTEXT as ``foxglove.Log``.
* ``px4/pose``: the autopilot's attitude (ATTITUDE_QUATERNION, else ATTITUDE) at its estimated
  position, as ``foxglove.PoseInFrame`` in an east-north-up ``map`` frame (FLU body).
* ``px4/location/estimate`` (GLOBAL_POSITION_INT) and ``px4/location/truth`` (the world's
  truth): two ``foxglove.LocationFix`` tracks; ``mcs/path/estimate`` and ``mcs/path/truth``
  the same in metres from home, for the plot.
* ``px4/mission``: the uploaded mission (MISSION_ITEM_INT) as ``foxglove.GeoJSON`` for the
  Map panel, and ``mcs/plan`` for the plot.
* The layout plots each position setpoint (POSITION_TARGET_LOCAL_NED) beside the estimate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..mavlink.hil import HilActuatorControls, HilGps, HilSensor, MavlinkPacket
from ..mavlink.mission import world_topics
from ..mavlink.trace import mission_trace
from ..trace import (
    TraceOptions,
)

if TYPE_CHECKING:
    from ..mavlink.mission import MuJoCo
    from .autopilot.firmware import AutopilotSpec

__all__ = ["trace_options"]


def trace_options(spec: AutopilotSpec, world: MuJoCo) -> TraceOptions:
    """Types, decoders and Foxglove channels of a PX4 simulation (see the module docstring)."""
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
        uplink=spec.uplink,
        downlink=spec.downlink,
        truth=topics.truth,
        home=world.home,
        types=types,
        links=(spec.uplink, spec.downlink, *(sorted(hil) if mavlink_wire else ())),
    )
