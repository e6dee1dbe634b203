"""The simulator interface between world and autopilot: PX4's HIL messages on topics.

The payloads mirror MAVLink's HIL_SENSOR, HIL_GPS and HIL_ACTUATOR_CONTROLS field for field
(same names, units and order). With ``wire="native"`` they travel as these Structs (free
in-process, MessagePack between processes); with ``wire="mavlink"`` every payload is a
``MavlinkPacket`` holding the packed MAVLink 2 frame, exactly what PX4 SITL exchanges
with its simulator. ``read_sensor`` and friends accept either, so an injector written
once works on both wires.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import msgspec

from ..physics.obstacles import NO_OBSTACLES, Proximity
from .dialect import decode_frames, dialect, new_link, pack_scalar, scalar_class

if TYPE_CHECKING:
    from ..core.geo import LocalProjection
    from ..physics.frames import NedState

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
    "truth",
    "unpack",
]

Wire = Literal["native", "mavlink"]

IMU_FIELDS = 0x3F  # HIL_SENSOR_UPDATED_{X,Y,Z}ACC | {X,Y,Z}GYRO
MAG_FIELDS = 0x1C0  # HIL_SENSOR_UPDATED_{X,Y,Z}MAG
BARO_FIELDS = 0x200 | 0x800 | 0x1000  # ABSPRESSURE | PRESSALT | TEMPERATURE

# HIL_ACTUATOR_CONTROLS.flags bit (outside the bits MAVLink defines) saying that controls
# 0..3 are a velocity setpoint (north, east, down m/s; yaw rad) rather than motor outputs.
# Only the low-fidelity point-mass vehicle, which has no motors, uses it.
ACTUATOR_FLAG_VELOCITY = 1 << 32


class HilSensor(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """HIL_SENSOR: IMU (FRD, m/s^2, rad/s), magnetometer (gauss), barometer (hPa, m, degC)."""

    time_usec: int
    xacc: float
    yacc: float
    zacc: float
    xgyro: float
    ygyro: float
    zgyro: float
    xmag: float
    ymag: float
    zmag: float
    abs_pressure: float
    diff_pressure: float
    pressure_alt: float
    temperature: float
    fields_updated: int
    id: int = 0


class HilGps(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """HIL_GPS: degE7 position, mm altitude (MSL), cm/s velocities, cdeg course."""

    time_usec: int
    fix_type: int
    lat: int
    lon: int
    alt: int
    eph: int
    epv: int
    vel: int
    vn: int
    ve: int
    vd: int
    cog: int
    satellites_visible: int
    id: int = 0
    yaw: int = 0


class HilActuatorControls(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """HIL_ACTUATOR_CONTROLS: 16 normalized outputs (motors 0..1), mode flags, flags."""

    time_usec: int
    controls: list[float]
    mode: int
    flags: int


class MavlinkPacket(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """Packed MAVLink 2 frames (one or more, concatenated) as a topic payload."""

    data: bytes


class Truth(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """The world's ground truth: local NED position (m) from home, velocity, WGS84 position,
    attitude (unit quaternion w, x, y, z rotating FRD body axes into NED), body rates and the
    specific force (m/s^2, body FRD: what an ideal accelerometer reads, gravity included), and
    how close the vehicle is to the world's obstacles (a
    [`Proximity`][multicosim.physics.Proximity]: clearances in m, infinite without obstacles; the
    obstacle touched now and the first one hit, -1 for none)."""

    time: float
    north: float
    east: float
    down: float
    vn: float
    ve: float
    vd: float
    lat: float
    lon: float
    alt: float  # above home
    qw: float = 1.0
    qx: float = 0.0
    qy: float = 0.0
    qz: float = 0.0
    rollspeed: float = 0.0
    pitchspeed: float = 0.0
    yawspeed: float = 0.0
    xacc: float = 0.0
    yacc: float = 0.0
    zacc: float = 0.0
    proximity: Proximity = NO_OBSTACLES


HilMessage = HilSensor | HilGps | HilActuatorControls
M = TypeVar("M", HilSensor, HilGps, HilActuatorControls)

_MAV_CLASSES = {
    HilSensor: "MAVLink_hil_sensor_message",
    HilGps: "MAVLink_hil_gps_message",
    HilActuatorControls: "MAVLink_hil_actuator_controls_message",
}
_FROM_MAV = {
    "HIL_SENSOR": HilSensor,
    "HIL_GPS": HilGps,
    "HIL_ACTUATOR_CONTROLS": HilActuatorControls,
}


class Packer:
    """Packs messages as the MAVLink 2 frames of one sender (``system``), numbered in sequence.

    Each publisher owns one: a frame's sequence number then depends on what its publisher
    sent, not on what else its process packed before, so a flight is the same bits in
    process, as processes and in containers, run after run.
    """

    def __init__(self, system: int = 1, component: int = 1) -> None:
        self._link: Any = new_link(system, component)

    def frame(self, mav_msg: Any) -> bytes:
        """A pymavlink message packed as the next frame."""
        data = bytes(mav_msg.pack(self._link))
        self._link.seq = (self._link.seq + 1) & 0xFF
        return data

    def pack(self, msg: HilMessage) -> MavlinkPacket:
        """``msg`` as the next packed frame."""
        cls = getattr(dialect(), _MAV_CLASSES[type(msg)])
        values = msgspec.structs.astuple(msg)
        if scalar_class(cls.id) is None:  # HIL_ACTUATOR_CONTROLS' array: pymavlink's path
            return MavlinkPacket(self.frame(cls(*values)))
        # The sensors' frames, at every world step: packed directly, as pymavlink packs them
        # (the message's extension fields, which the Struct leaves out, zero).
        wire = [0] * len(cls.orders)
        for position, value in zip(cls.orders, values, strict=False):
            wire[position] = value
        data = pack_scalar(self._link, cls, *wire)
        # What a receiver decodes (floats rounded to 32 bits), for one in this process that
        # gets this very bytes object: it need not parse the frame (see unpack).
        t = cls.unpacker.unpack(cls.unpacker.pack(*wire))
        _packed.append((data, type(msg)(*(t[i] for i in cls.orders[: len(values)]))))
        return MavlinkPacket(data)

    def write(self, msg: HilMessage, wire: Wire) -> HilMessage | MavlinkPacket:
        """The payload to publish for ``msg`` on ``wire``."""
        return msg if wire == "native" else self.pack(msg)


def from_mavlink(mav_msg: object) -> HilMessage | None:
    """The HIL payload equal to a decoded pymavlink message (None for other messages)."""
    cls = _FROM_MAV.get(mav_msg.get_type())  # type: ignore[attr-defined]
    if cls is None:
        return None
    hil: HilMessage = cls(*(getattr(mav_msg, f) for f in cls.__struct_fields__))
    return hil


_parser: list[object] = []
# The latest frames packed in this process, each with its message as decoded: a receiver in
# this process that gets the very same bytes object takes the message instead of parsing.
_packed: deque[tuple[bytes, HilMessage]] = deque(maxlen=16)


def unpack(packet: MavlinkPacket) -> list[HilMessage]:
    """The HIL messages inside ``packet`` (other MAVLink messages are skipped)."""
    data = packet.data
    for packed, message in reversed(_packed):
        if packed is data:
            return [message]
    if not _parser:
        _parser.append(new_link(0, 0))
    parser: Any = _parser[0]
    out: list[HilMessage] = []
    for m in decode_frames(parser, data):
        hil = from_mavlink(m)
        if hil is not None:
            out.append(hil)
    return out


def read(payload: object, tp: type[M]) -> M | None:
    """The ``tp`` message carried by ``payload`` (native or MAVLink), or None."""
    if isinstance(payload, tp):
        return payload
    if isinstance(payload, MavlinkPacket):
        for m in unpack(payload):
            if isinstance(m, tp):
                return m
    return None


def write(msg: HilMessage, wire: Wire, packer: Packer | None = None) -> HilMessage | MavlinkPacket:
    """The payload to publish for ``msg`` on ``wire``: a frame numbered by ``packer`` (the
    publisher's own, see ``Packer``), else a frame of its own (sequence number 0)."""
    return (packer or Packer()).write(msg, wire)


def payload_type(wire: Wire, tp: type[M]) -> type[M] | type[MavlinkPacket]:
    """The type to subscribe a HIL topic with on ``wire``."""
    return tp if wire == "native" else MavlinkPacket


def truth(
    time: float,
    state: NedState,
    projection: LocalProjection,
    proximity: Proximity = NO_OBSTACLES,
) -> Truth:
    """The world's Truth message for ``state`` at simulated ``time`` (WGS84 via ``projection``)."""
    ned, vel, q, accel, gyro = state
    lat, lon = projection.reproject(ned[0], ned[1])
    return Truth(
        time, *ned, *vel, lat, lon, -ned[2], *q, *gyro, *accel,
        proximity,
    )  # fmt: skip
