"""Our PX4-compatible autopilot: a participant stepped in lockstep with the world.

It is assembled from parts, one concern per module (see ``state``): the flight logic
(``commander``: arming, modes, failsafes, land detector; ``navigator``: what to
fly per mode; ``control``; ``estimator``; ``failures``: sensor intake with
PX4's failure injection) and the MAVLink server (``offboard``, ``streams``,
``commands``, ``paramserver``, ``missions``). Outside, it looks like PX4 to
both of its peers:

* simulator side: HIL_SENSOR / HIL_GPS in, HIL_ACTUATOR_CONTROLS out (topics ``topics.*``);
* ground-station side: MAVLink 2 as PX4 presents it, as packed frames on the ``uplink`` /
  ``downlink`` topics. ``multicosim.px4.standalone`` carries those topics over UDP.
"""

from __future__ import annotations

import logging
import math
from typing import Any, Literal

import msgspec

from ...core.errors import ConfigurationError
from ...mavlink import dialect as _mav
from ...mavlink.dialect import MISSION_STATE_NO_MISSION, decode_frames, dialect, new_link
from ...mavlink.hil import HilGps, HilSensor, MavlinkPacket, Packer, Truth, Wire, unpack
from ...quadrotor.topics import Topics
from ...runtime.context import StepContext, Subscription
from ..modes import MainMode, Mode, SubMode
from .commander import Commander
from .commands import Commands
from .control import MultirotorController
from .estimator import Estimator
from .failures import Failures
from .missions import Missions
from .navigator import Navigator
from .offboard import Server
from .params import Params
from .paramserver import ParamServer
from .state import Item
from .streams import GCS_STREAMS, Streams, onboard_streams

__all__ = ["Autopilot", "AutopilotSpec", "Item", "MainMode", "SubMode", "autopilot"]

log = logging.getLogger(__name__)

Airframe = Literal["quadrotor", "point_mass"]
StreamProfile = Literal["gcs", "onboard"]


class AutopilotSpec(msgspec.Struct, frozen=True, kw_only=True):
    """Configuration of the autopilot participant (JSON-encodable, for a process).

    ``streams``: ``gcs`` sends what the built-in ground station reads; ``onboard`` sends
    what real PX4 sends on its API link (the standalone SITL's links).
    """

    airframe: Airframe = "quadrotor"
    period: float = 0.004
    topics: Topics = msgspec.field(default_factory=Topics)
    uplink: str = "px4/mavlink/up"
    downlink: str = "px4/mavlink/down"
    wire: Wire = "native"
    telemetry_rate: float = 20.0
    streams: StreamProfile = "gcs"
    params: dict[str, float] = msgspec.field(default_factory=dict)
    mag_declination: float = 0.0  # rad, the world's (PX4 looks it up in its field model)

    def __post_init__(self) -> None:
        if self.airframe not in ("quadrotor", "point_mass"):
            raise ConfigurationError("airframe", self.airframe, "'quadrotor' or 'point_mass'")
        if not 0.0005 <= self.period <= 0.2:
            raise ConfigurationError("period", self.period, "a period in [0.0005, 0.2] s")
        if not 1.0 <= self.telemetry_rate <= 100.0:
            raise ConfigurationError("telemetry_rate", self.telemetry_rate, "1..100 Hz")
        if self.streams not in ("gcs", "onboard"):
            raise ConfigurationError("streams", self.streams, "'gcs' or 'onboard'")
        Params(self.params)  # validates names and ranges


class Autopilot(Commander, Navigator, Failures, Commands, ParamServer, Missions, Streams, Server):
    """The autopilot participant (see the module docstring)."""

    def __init__(self, spec: AutopilotSpec | None = None) -> None:
        self.spec = spec = spec or AutopilotSpec()
        self.period = spec.period
        self.params = Params(spec.params)
        self.est = Estimator(spec.mag_declination, self.params)
        self.ctl = MultirotorController()
        self.velocity_vehicle = spec.airframe == "point_mass"
        self._d = dialect()
        # PX4 reads its MAVLink system id from MAV_SYS_ID once, at boot.
        self.system_id = int(self.params["MAV_SYS_ID"])
        self.mav = new_link(self.system_id, 1)
        self._out = []
        self._out_msgs = []
        self._subs: list[tuple[Subscription[Any], bool]] = []
        self._uplink: Subscription[MavlinkPacket] | None = None
        self._truth: Subscription[Truth] | None = None
        self.truth = None
        self._now = 0.0
        self._last_imu_us = None
        self.failures = {}
        self.motors_off = set()
        # Commander state.
        self.armed = False
        self.mode = Mode.LOITER
        self.landed = True
        self.failsafe = None
        self._offboard_lost = False
        self._armed_at = 0.0
        self._flew = False
        self._landed_at = None
        self._ground_d = 0.0
        self._touch_since = None
        self.home = None
        # Navigator state.
        self.mission = []
        self.fence = []
        self.rally = []
        self.seq = 0
        self.mission_state = MISSION_STATE_NO_MISSION
        self._jumps = {}
        self._phase = ""
        self._hold = (0.0, 0.0, 0.0)
        self._leg_origin = (0.0, 0.0)  # where the current mission leg began (north, east)
        self._leg_speed = math.inf  # the fastest the leg may be flown here (a turn ahead)
        self._target = None
        self._cruise = None
        self._yaw_sp = 0.0
        self._vz_sp = 0.0
        self._pos_sp = None
        self._vel_sp = None
        self._reached_at = None
        self._offboard = None
        self._manual = None
        self._follow = None
        self._follow_course = 0.0
        self._follow_angle = None
        self._follow_adjust = [0.0, 0.0, 0.0]
        # Ground-station link state.
        self._gcs = (255, 190)
        self._upload = None
        self._after_ack = []
        self._dirty = set()
        self._param_queue = []
        self._param_index = {}
        profile = onboard_streams() if spec.streams == "onboard" else GCS_STREAMS
        self._init_streams(profile, spec.telemetry_rate)

    # -- participant ------------------------------------------------------------------------

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the sensor topics and the ground-station uplink."""
        t = self.spec.topics
        native = self.spec.wire == "native"
        self._packer = Packer()
        seen: set[str] = set()
        for topic in (t.imu, t.mag, t.baro, t.gps):
            if topic in seen:
                continue
            seen.add(topic)
            if not native:
                self._subs.append((ctx.subscribe(topic, MavlinkPacket), False))
            else:
                tp: type[Any] = HilGps if topic == t.gps else HilSensor
                self._subs.append((ctx.subscribe(topic, tp), True))
        self._uplink = ctx.subscribe(self.spec.uplink, MavlinkPacket)
        if self.spec.streams == "onboard":
            # Ground truth for HIL_STATE_QUATERNION, as PX4 SITL forwards its simulator's.
            self._truth = ctx.subscribe(t.truth, Truth)

    def step(self, ctx: StepContext) -> None:
        """One autopilot cycle: sensors, ground station, commander, navigator, control."""
        self._now = ctx.time
        for sub, native in self._subs:
            if sub.fresh:
                for payload in sub.messages:
                    if native:
                        self._sensor(payload)
                    else:
                        for m in unpack(payload):
                            self._sensor(m)
        truth = self._truth
        if truth is not None and truth.fresh:
            self.truth = truth.messages[-1]
        up = self._uplink
        if up is not None and up.fresh:
            for packet in up.messages:
                for m in decode_frames(self.mav, packet.data):
                    self._handle(m)
        if self._upload is not None:
            self._upload_tick()
        if self._param_queue:
            self._param_tick()
        self._commander()
        self.est.in_air = not self.landed
        out = self._navigate_and_control()
        ctx.publish(self.spec.topics.actuators, self._packer.write(out, self.spec.wire))
        self._stream()
        if self._out:
            data = b"".join(self._out)
            # An in-process ground station gets the messages without parsing the frames.
            _mav.remember(data, list(zip(self._out, self._out_msgs, strict=True)))
            ctx.publish(self.spec.downlink, MavlinkPacket(data))
            self._out = []
            self._out_msgs = []


def autopilot(spec: AutopilotSpec) -> Autopilot:
    """The participant of ``multicosim participant multicosim.px4.autopilot.firmware:autopilot``."""
    return Autopilot(spec)
