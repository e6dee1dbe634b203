"""The simulator interface's payloads, for components placed between world and autopilot.

An injector (a GPS attack, a sensor fault) subscribes to the world's topic, changes what it
reads and publishes on the topic the autopilot reads (``px4.Topics`` remaps them). Payloads
are the MAVLink HIL messages as Structs (``wire="native"``, low fidelity) or packed MAVLink
frames (``MavlinkPacket``, between processes at medium fidelity); ``read`` and
``write`` handle both:

```python
msg = hil.read(payload, hil.HilGps)          # None if the payload holds no HIL_GPS
moved = msgspec.structs.replace(msg, lat=msg.lat + 100)
ctx.publish("px4/gps/attacked", hil.write(moved, wire, packer))  # packer: hil.Packer()
```
"""

from __future__ import annotations

from ..mavlink.hil import (
    ACTUATOR_FLAG_VELOCITY,
    BARO_FIELDS,
    IMU_FIELDS,
    MAG_FIELDS,
    HilActuatorControls,
    HilGps,
    HilSensor,
    MavlinkPacket,
    Packer,
    Truth,
    Wire,
    payload_type,
    read,
    unpack,
    write,
)

__all__ = [
    "ACTUATOR_FLAG_VELOCITY",
    "BARO_FIELDS",
    "IMU_FIELDS",
    "MAG_FIELDS",
    "HilActuatorControls",
    "HilGps",
    "HilSensor",
    "MavlinkPacket",
    "Packer",
    "Truth",
    "Wire",
    "payload_type",
    "read",
    "unpack",
    "write",
]
