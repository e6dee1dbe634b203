"""Sensor faults and attacks on ArduPilot: [`multicosim.attacks`][multicosim.attacks] models as its
own faults.

ArduPilot synthesises its GPS and barometer from the state our world sends, and its SITL
simulates their faults itself, set by ``SIM_*`` parameters. The attack models map onto those
parameters, set over MAVLink (PARAM_SET, confirmed by ArduPilot's PARAM_VALUE) when a
model's window opens, updated while it acts and restored when it closes, so ArduPilot's EKF3
meets the fault where a real receiver would put it:

========================  ==============================  ====================================
model                     GPS (``"gps"``)                 barometer (``"baro"``)
========================  ==============================  ====================================
Gaussian, Bias, Drift,    ``SIM_GPS_GLITCH_X/Y/Z``: the   ``SIM_BARO_GLITCH``: the models'
Jump (position offsets)   models' summed offset (north,   summed altitude offset (m)
                          east as degrees, up in m)
Dropout                   ``SIM_GPS_DISABLE`` 1 (no fix)  ``SIM_BARO_DISABLE`` 1
Delay                     ``SIM_GPS_LAG_MS`` + the delay  ``SIM_BARO_DELAY`` + the delay
========================  ==============================  ====================================

The offsets are recomputed every ``period`` (0.2 s: ArduPilot's simulated receiver gives a
fix at 5 Hz, ``SIM_GPS_HZ``), with the seeded generator for random models, so Gaussian
noise is a fresh draw per fix and a seed gives the same faults every run. Only what changed
is sent. ArduPilot not confirming a parameter is an error naming it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import msgspec

from ..attacks.models import (
    Additive,
    Delay,
    Dropout,
    Model,
    Offsets,
    check_models,
    subscribe_streams,
)
from ..attacks.sensors import ENU
from ..core.errors import ConfigurationError, MulticosimError
from ..core.geo import Home, LocalProjection
from ..core.interfaces import Node
from ..local import InProcessComponent, LocalEnvironment
from ..mavlink.dialect import decode_frames, new_link
from ..mavlink.hil import MavlinkPacket
from ..runtime.context import StepContext, Subscription
from ._bridge import DOWNLINK, UPLINK

__all__ = ["SENSORS", "FaultsComponent", "FaultsConfig", "SimulatedFaults"]

# Per sensor: its quantity (name, axes), the offset parameters, dropout, delay (and the
# delay's default: ArduPilot's SIM_GPS_LAG_MS is 100 ms).
SENSORS: dict[str, dict[str, Any]] = {
    "gps": {
        "quantity": ("position", ENU),
        "offset": ("SIM_GPS_GLITCH_X", "SIM_GPS_GLITCH_Y", "SIM_GPS_GLITCH_Z"),
        "dropout": "SIM_GPS_DISABLE",
        "delay": ("SIM_GPS_LAG_MS", 100.0),
    },
    "baro": {
        "quantity": ("altitude", ("up",)),
        "offset": ("SIM_BARO_GLITCH",),
        "dropout": "SIM_BARO_DISABLE",
        "delay": ("SIM_BARO_DELAY", 0.0),
    },
}
ALIASES = {"position": "gps", "barometer": "baro"}
CONFIRM_TIMEOUT = 1.0  # s of simulated time for ArduPilot to echo a PARAM_SET
TRIES = 3


class FaultsConfig(msgspec.Struct, frozen=True, kw_only=True):
    """Which ArduPilot sensor gets which models; validated on construction.

    ``sensor`` is ``"gps"`` (alias ``"position"``) or ``"baro"`` (``"barometer"``);
    additive models act on its position (metres east/north/up) or altitude (metres up).
    ``home`` converts GPS offsets to degrees; ``uplink``/``downlink`` are ArduPilot's
    MAVLink topics; ``period`` (s) how often the faults are brought up to date.
    """

    sensor: str
    models: tuple[Model, ...]
    home: Home = Home()
    uplink: str = UPLINK
    downlink: str = DOWNLINK
    period: float = 0.2

    def __post_init__(self) -> None:
        sensor = ALIASES.get(self.sensor, self.sensor) if isinstance(self.sensor, str) else None
        if sensor not in SENSORS:
            raise ConfigurationError(
                "sensor",
                self.sensor,
                f"a sensor ArduPilot simulates faults of: one of {tuple(SENSORS)} "
                f"(or {tuple(ALIASES)})",
            )
        msgspec.structs.force_setattr(self, "sensor", sensor)
        quantity, axes = SENSORS[sensor]["quantity"]
        models = check_models(
            self.models, {quantity: axes}, quantity, f"ArduPilot's simulated {sensor} faults"
        )
        msgspec.structs.force_setattr(self, "models", models)
        period = self.period
        if isinstance(period, bool) or not isinstance(period, int | float) or not 0 < period <= 1:
            raise ConfigurationError("period", period, "0 < period <= 1 s")


class SimulatedFaults:
    """A participant keeping ArduPilot's simulated faults of one sensor as the models say."""

    def __init__(self, config: FaultsConfig) -> None:
        self.config = config
        self.period = config.period
        spec = SENSORS[config.sensor]
        self._spec = spec
        additive = [m for m in config.models if isinstance(m, Additive)]
        quantity, axes = spec["quantity"]
        self._offsets = Offsets(additive, axes, quantity) if additive else None
        self._dropouts = [m for m in config.models if isinstance(m, Dropout)]
        self._delays = [m for m in config.models if isinstance(m, Delay)]
        self._projection = LocalProjection.at(config.home)
        self._mav: Any = new_link(255, 191, "ardupilotmega")
        self._down: Subscription[MavlinkPacket] | None = None
        self._sent: dict[str, float] = {}  # what ArduPilot was told last
        delay_name, delay_default = spec["delay"]
        self._baseline = {delay_name: delay_default}  # ArduPilot's values without faults
        self._pending: dict[str, tuple[float, float, int]] = {}  # value, sent at, tries
        # ArduPilot's system id: instance N is system N + 1 (learnt from its heartbeat;
        # a PARAM_SET sent before it arrives is resent when unconfirmed).
        self._target: tuple[int, int] | None = None
        self.updates = 0

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to ArduPilot's MAVLink (for its PARAM_VALUE echoes), and to the topics
        of Stream models."""
        self._down = ctx.subscribe(self.config.downlink, MavlinkPacket)
        if self._offsets is not None:
            subscribe_streams(ctx, self.config.models, [self._offsets])

    def wanted(self, time: float, rng: Any) -> dict[str, float]:
        """The fault parameters' values at simulated ``time``."""
        spec = self._spec
        values: dict[str, float] = {}
        names = spec["offset"]
        offset = self._offsets.at(time, rng) if self._offsets is not None else None
        if offset is None:
            values.update(dict.fromkeys(names, 0.0))
        elif len(names) == 3:
            east, north, up = offset
            home = self._projection
            lat, lon = home.reproject(north, east)
            values.update(zip(names, (lat - home.lat, lon - home.lon, up), strict=True))
        else:
            values[names[0]] = offset[0]
        if self._dropouts:
            values[spec["dropout"]] = float(any(m.active(time) for m in self._dropouts))
        if self._delays:
            name, default = spec["delay"]
            delay = max((m.delay for m in self._delays if m.active(time)), default=0.0)
            values[name] = default + round(delay * 1000.0)
        return values

    def step(self, ctx: StepContext) -> None:
        """Confirm what ArduPilot echoed; set what changed; resend what it did not confirm."""
        self._confirm()
        now = ctx.time
        for name, value in self.wanted(now, ctx.rng).items():
            # ArduPilot starts without faults: a parameter is first set when it departs
            # from that, then whenever it changes.
            if self._sent.get(name, self._baseline.get(name, 0.0)) != value:
                self._set(ctx, name, value, 1)
        for name, (value, sent_at, tries) in list(self._pending.items()):
            if now - sent_at >= CONFIRM_TIMEOUT:
                if tries >= TRIES:
                    raise MulticosimError(
                        f"ArduPilot did not accept the simulated fault {name}={value:g} "
                        f"({TRIES} PARAM_SETs unanswered): is the parameter in this firmware?"
                    )
                self._set(ctx, name, value, tries + 1)

    def _set(self, ctx: StepContext, name: str, value: float, tries: int) -> None:
        mav = self._mav
        system, component = self._target or (1, 1)
        msg = mav.param_set_encode(system, component, name.encode(), value, 9)
        ctx.publish(self.config.uplink, MavlinkPacket(bytes(msg.pack(mav))))
        mav.seq = (mav.seq + 1) & 0xFF
        self._sent[name] = value
        self._pending[name] = (value, ctx.time, tries)
        self.updates += 1

    def _confirm(self) -> None:
        down = self._down
        if down is None or not down.fresh or (self._target is not None and not self._pending):
            return
        for packet in down.messages:
            for m in decode_frames(self._mav, packet.data):
                kind = m.get_type()
                if kind == "HEARTBEAT" and self._target is None:
                    self._target = (m.get_srcSystem(), m.get_srcComponent())
                if kind != "PARAM_VALUE":
                    continue
                name = m.param_id if isinstance(m.param_id, str) else m.param_id.decode()
                name = name.split("\0", 1)[0]
                pending = self._pending.get(name)
                if pending is not None and abs(m.param_value - pending[0]) <= 1e-6 * max(
                    1.0, abs(pending[0])
                ):
                    del self._pending[name]


@dataclasses.dataclass(frozen=True)
class FaultsComponent:
    """The simulated faults as a component (in the simulation's process, beside ArduPilot)."""

    config: FaultsConfig
    name: str = "faults"

    def __post_init__(self) -> None:
        if not isinstance(self.config, FaultsConfig):
            raise ConfigurationError("config", self.config, "a FaultsConfig")
        if not isinstance(self.name, str) or not self.name:
            raise ConfigurationError("name", self.name, "a non-empty component name")

    def start(self, environment: LocalEnvironment) -> Node:
        """Start it in this process."""
        config = self.config
        return InProcessComponent(lambda: SimulatedFaults(config), self.name).start(environment)
