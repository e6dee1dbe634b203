"""The physics world's configuration (the role of the paper's ``Gazebo(backend=ODE(...))``).

Importing this module does not import MuJoCo: a configuration can be built, validated and
sent to a world process from an environment where MuJoCo is not installed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Literal

from ..core.errors import ConfigurationError
from ..core.geo import Home
from .obstacles import Box, Cylinder, check_obstacles
from .wind import Wind

__all__ = [
    "DEFAULT_HOME",
    "DEFAULT_MAGNETIC_FIELD",
    "INTEGRATORS",
    "SOLVERS",
    "Integrator",
    "Solver",
    "WorldConfig",
    "check_sensor_topics",
]

Integrator = Literal["Euler", "RK4", "implicit", "implicitfast"]
Solver = Literal["Newton", "CG", "PGS"]

INTEGRATORS: tuple[Integrator, ...] = ("Euler", "RK4", "implicit", "implicitfast")
SOLVERS: tuple[Solver, ...] = ("Newton", "CG", "PGS")

DEFAULT_HOME = Home()
# Earth's field near that home (ENU frame, tesla): about 21.5 uT north, 43 uT down.
DEFAULT_MAGNETIC_FIELD = (0.0, 2.15e-5, -4.3e-5)

# Beyond these a world would only fail once running: a period of 10^7 MuJoCo steps outlasts
# any step timeout, and MuJoCo keeps ``iterations`` in a C int.
MIN_TIMESTEP = 1e-4
MAX_TIMESTEP = 0.1
MAX_NOISE = 10.0
MAX_ITERATIONS = 1000


def _number(field: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigurationError(field, value, "a finite number")
    return float(value)


@dataclasses.dataclass(frozen=True, kw_only=True)
class WorldConfig:
    """How the physics world is simulated; validated on construction.

    ``timestep`` is MuJoCo's integration step (1e-4 <= timestep <= 0.1 s), ``iterations``
    its solver's iteration limit (1 to 1000); ``period`` is how
    often the world exchanges messages (publishes sensors, reads actuator commands): the
    world integrates ``period / timestep`` MuJoCo steps in one batch between exchanges.
    ``sensor_topics`` maps a sensor's name to the topic it is published on instead of its
    default one, so that an injector can sit between a sensor and its reader. ``home`` is
    the (latitude, longitude, altitude) of the local origin (a [`Home`][multicosim.core.geo.Home]);
    ``magnetic_field`` is Earth's field in the local ENU frame (tesla). ``noise`` scales the
    vehicle's sensor-noise model: 0 gives ideal sensors, 1 the vehicle's realistic model.
    ``obstacles`` are [`Box`][multicosim.physics.Box] and [`Cylinder`][multicosim.physics.Cylinder]
    standing on the ground (none may overlap another or stand within 1 m of home); ``wind``
    is the air's motion ([`Wind`][multicosim.physics.Wind]; None: still air and no
    aerodynamic drag beyond MuJoCo's own).
    """

    timestep: float = 0.002
    integrator: Integrator = "implicitfast"
    solver: Solver = "Newton"
    iterations: int = 100
    period: float = 0.01
    sensor_topics: dict[str, str] = dataclasses.field(default_factory=dict)
    home: Home = DEFAULT_HOME
    magnetic_field: tuple[float, float, float] = DEFAULT_MAGNETIC_FIELD
    noise: float = 1.0
    obstacles: tuple[Box | Cylinder, ...] = ()
    wind: Wind | None = None

    def __post_init__(self) -> None:
        timestep = _number("timestep", self.timestep)
        if not MIN_TIMESTEP <= timestep <= MAX_TIMESTEP:
            raise ConfigurationError(
                "timestep", self.timestep, f"{MIN_TIMESTEP:g} <= timestep <= {MAX_TIMESTEP:g} s"
            )
        if self.integrator not in INTEGRATORS:
            raise ConfigurationError("integrator", self.integrator, f"one of {INTEGRATORS}")
        if self.solver not in SOLVERS:
            raise ConfigurationError("solver", self.solver, f"one of {SOLVERS}")
        if (
            isinstance(self.iterations, bool)
            or not isinstance(self.iterations, int)
            or not 1 <= self.iterations <= MAX_ITERATIONS
        ):
            raise ConfigurationError(
                "iterations", self.iterations, f"an integer in 1..{MAX_ITERATIONS}"
            )
        period = _number("period", self.period)
        if not timestep <= period <= 1.0:
            raise ConfigurationError(
                "period", self.period, f"timestep ({timestep:g} s) <= period <= 1 s"
            )
        if not isinstance(self.sensor_topics, Mapping) or not all(
            isinstance(k, str) and k and isinstance(v, str) and v
            for k, v in self.sensor_topics.items()
        ):
            raise ConfigurationError(
                "sensor_topics", self.sensor_topics, "a mapping of sensor name to topic name"
            )
        home = self.home
        if not isinstance(home, tuple | list) or len(home) != 3:
            raise ConfigurationError("home", home, "(latitude, longitude, altitude)")
        lat, lon, _ = (_number("home", v) for v in home)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise ConfigurationError(
                "home", home, "latitude in [-90, 90] and longitude in [-180, 180] degrees"
            )
        field = self.magnetic_field
        if not isinstance(field, tuple | list) or len(field) != 3:
            raise ConfigurationError("magnetic_field", field, "an (east, north, up) vector")
        for v in field:
            _number("magnetic_field", v)
        noise = _number("noise", self.noise)
        if not 0.0 <= noise <= MAX_NOISE:
            raise ConfigurationError("noise", self.noise, f"0 <= noise <= {MAX_NOISE:g}")
        obstacles = check_obstacles(self.obstacles, (lat, lon, 0.0))
        if self.wind is not None and not isinstance(self.wind, Wind):
            raise ConfigurationError("wind", self.wind, "None or a physics.Wind")
        # Decoded from JSON these arrive as lists; keep them tuples so configs compare equal.
        object.__setattr__(self, "obstacles", obstacles)
        object.__setattr__(self, "home", Home(*(float(v) for v in home)))
        object.__setattr__(self, "noise", noise)
        object.__setattr__(self, "magnetic_field", tuple(float(v) for v in field))
        object.__setattr__(self, "sensor_topics", dict(self.sensor_topics))

    @property
    def steps_per_period(self) -> int:
        """MuJoCo steps integrated between two exchanges (rounded)."""
        return max(1, round(self.period / self.timestep))

    @property
    def declination(self) -> float:
        """Magnetic declination of ``magnetic_field`` (rad, east of true north)."""
        east, north, _ = self.magnetic_field
        return math.atan2(east, north)

    def topic(self, sensor: str, default: str) -> str:
        """The topic ``sensor`` is published on: its remapping, else ``default``."""
        return self.sensor_topics.get(sensor, default)


def check_sensor_topics(config: WorldConfig, sensors: Mapping[str, str]) -> None:
    """Raise ConfigurationError if ``config`` remaps a sensor that ``sensors`` does not name."""
    unknown = sorted(set(config.sensor_topics) - set(sensors))
    if unknown:
        raise ConfigurationError(
            "sensor_topics", unknown[0], f"a sensor name, one of {sorted(sensors)}"
        )
