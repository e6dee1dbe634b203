"""Messages of the F-16: where a flight starts, the state it publishes, the flight it makes.

Units are AeroBench's (and the ARCH-COMP benchmark's): feet, feet per second, radians.
Positions are north, east and altitude above the ground; attitudes are Euler angles (roll,
pitch, yaw from north).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from ..core.errors import ConfigurationError
from ..core.messages import Message

__all__ = [
    "GCAS_MODES",
    "STATE_TOPIC",
    "F16State",
    "Flight",
    "InitialState",
]

STATE_TOPIC = "f16/state"
"""The topic the F-16 publishes its state on, every step."""

GCAS_MODES = ("standby", "roll", "pull", "waiting")
"""The GCAS autopilot's modes (AeroBench's names): standby, roll wings level, pull up,
waiting (a time-triggered start)."""

# The flight envelope an initial state must lie in: where AeroBench's aerodynamic tables
# are defined (angle of attack -10 to 45 degrees, sideslip up to 30, altitude up to the
# thrust table's 50,000 ft), at airspeeds from near stall to Mach 1 at sea level.
MAX_ALTITUDE = 50_000.0
AIRSPEED = (300.0, 1100.0)
ALPHA = (math.radians(-10.0), math.radians(45.0))
MAX_BETA = math.radians(30.0)
MAX_RATE = 2 * math.pi  # rad/s, about any axis
MAX_POSITION = 1e7  # ft, north or east of the origin


def _check(field: str, value: object, lo: float, hi: float, allowed: str) -> None:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or not lo <= value <= hi
    ):
        raise ConfigurationError(field, value, allowed)


class InitialState(Message):
    """Where a flight starts: AeroBench's thirteen state variables, checked on construction.

    The defaults are the ARCH-COMP benchmark's trimmed flight (540 ft/s, angle of attack
    2.1215 degrees, engine power 9) at its altitude of 4040 ft, wings and nose level.

    Raises:
        ConfigurationError: naming the field that lies outside the flight envelope.
    """

    altitude: float = 4040.0
    """Feet above the ground (0 < altitude <= 50,000)."""
    airspeed: float = 540.0
    """True airspeed, ft/s (300 to 1100)."""
    alpha: float = math.radians(2.1215)
    """Angle of attack, rad (-10 to 45 degrees)."""
    beta: float = 0.0
    """Sideslip angle, rad (at most 30 degrees either way)."""
    roll: float = 0.0
    """Roll angle from wings level, rad (-pi to pi)."""
    pitch: float = 0.0
    """Pitch angle from nose level, rad (-pi/2 to pi/2)."""
    yaw: float = 0.0
    """Yaw angle from north, rad (-pi to pi)."""
    roll_rate: float = 0.0
    """Body roll rate P, rad/s."""
    pitch_rate: float = 0.0
    """Body pitch rate Q, rad/s."""
    yaw_rate: float = 0.0
    """Body yaw rate R, rad/s."""
    north: float = 0.0
    """Feet north of the origin."""
    east: float = 0.0
    """Feet east of the origin."""
    power: float = 9.0
    """Engine power level (AeroBench's power-lag state, 0 to 100)."""

    def __post_init__(self) -> None:
        _check(
            "altitude",
            self.altitude,
            math.ulp(0.0),
            MAX_ALTITUDE,
            f"0 < altitude <= {MAX_ALTITUDE:g} ft (above the ground)",
        )
        _check("airspeed", self.airspeed, *AIRSPEED, "300 <= airspeed <= 1100 ft/s")
        _check("alpha", self.alpha, *ALPHA, "-10 to 45 degrees (in rad)")
        _check("beta", self.beta, -MAX_BETA, MAX_BETA, "-30 to 30 degrees (in rad)")
        for field in ("roll", "yaw"):
            _check(field, getattr(self, field), -math.pi, math.pi, "-pi <= angle <= pi rad")
        _check("pitch", self.pitch, -math.pi / 2, math.pi / 2, "-pi/2 <= pitch <= pi/2 rad")
        for field in ("roll_rate", "pitch_rate", "yaw_rate"):
            value = getattr(self, field)
            _check(field, value, -MAX_RATE, MAX_RATE, "at most 2 pi rad/s either way")
        for field in ("north", "east"):
            value = getattr(self, field)
            _check(field, value, -MAX_POSITION, MAX_POSITION, "a finite position in ft")
        _check("power", self.power, 0.0, 100.0, "0 <= power <= 100")

    def vector(self) -> list[float]:
        """The state in AeroBench's order: vt, alpha, beta, phi, theta, psi, P, Q, R,
        north, east, altitude, power."""
        return [
            float(v)
            for v in (
                self.airspeed,
                self.alpha,
                self.beta,
                self.roll,
                self.pitch,
                self.yaw,
                self.roll_rate,
                self.pitch_rate,
                self.yaw_rate,
                self.north,
                self.east,
                self.altitude,
                self.power,
            )
        ]


class F16State(Message):
    """The F-16's state at ``time`` (simulated s), as it publishes it every step.

    The fields are AeroBench's state variables (see
    [`InitialState`][multicosim.f16._messages.InitialState]) and ``mode``, the GCAS autopilot's mode
    then.
    """

    time: float
    altitude: float
    airspeed: float
    alpha: float
    beta: float
    roll: float
    pitch: float
    yaw: float
    roll_rate: float
    pitch_rate: float
    yaw_rate: float
    north: float
    east: float
    power: float
    mode: str


class Flight(Message):
    """A flight: the F-16's state at every step, from the initial state on.

    Iterating gives the samples; ``Requirement.evaluate`` reads its numeric fields as
    signals (``altitude``, ``roll``, ``pitch``, ``airspeed``, ...). ``fidelity`` is the
    level it was flown at (empty where it was flown outside a scenario).
    """

    samples: list[F16State]
    fidelity: str = ""

    def __iter__(self) -> Iterator[F16State]:
        return iter(self.samples)

    def __len__(self) -> int:
        return len(self.samples)

    @property
    def times(self) -> list[float]:
        """The sample times (simulated s)."""
        return [s.time for s in self.samples]

    @property
    def altitude(self) -> list[float]:
        """The altitude at every sample (ft)."""
        return [s.altitude for s in self.samples]

    @property
    def lowest(self) -> F16State:
        """The sample where the F-16 flew lowest (the first, if several)."""
        if not self.samples:
            raise ConfigurationError("samples", [], "a flight of at least one sample")
        return min(self.samples, key=lambda s: s.altitude)

    @property
    def final(self) -> F16State:
        """The last sample."""
        if not self.samples:
            raise ConfigurationError("samples", [], "a flight of at least one sample")
        return self.samples[-1]

    def modes(self) -> list[tuple[float, str]]:
        """The GCAS modes in the order they were entered, with the time of each entry."""
        entered: list[tuple[float, str]] = []
        for s in self.samples:
            if not entered or entered[-1][1] != s.mode:
                entered.append((s.time, s.mode))
        return entered
