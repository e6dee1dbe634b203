"""What a fleet's flight gives back: each vehicle's mission result and the encounter."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence

import msgspec

from ..mavlink.mission import Configuration, MissionResult
from ..physics.encounter import PairSample

__all__ = [
    "Approach",
    "Encounter",
    "FleetMissions",
    "FleetResult",
    "LossOfWellClear",
    "VehicleCollision",
    "pair_name",
    "signal_names",
]


def pair_name(a: str, b: str) -> str:
    """The name of a pair of vehicles, ``alpha-bravo`` (in the fleet's order)."""
    return f"{a}-{b}"


class FleetMissions(msgspec.Struct, frozen=True):
    """What the fleet flies: a mission per vehicle, by name (vehicles without one wait)."""

    missions: dict[str, Configuration]


class VehicleCollision(msgspec.Struct, frozen=True, kw_only=True):
    """Vehicles ``a`` and ``b`` touched at simulated ``time`` (s), closing at ``speed`` (m/s);
    ``source`` says how it was found: ``"contact"`` (MuJoCo's) or ``"analytic"`` (their
    bodies' spheres, from the states and velocities, between two samples)."""

    a: str
    b: str
    time: float
    speed: float
    source: str = "analytic"


class Approach(msgspec.Struct, frozen=True, kw_only=True):
    """A pair's closest approach over the flight: ``separation`` (m, bodies) at ``time``,
    with the midpoint between them (``north``/``east``/``up`` m from home)."""

    separation: float
    time: float
    north: float
    east: float
    up: float


class LossOfWellClear(msgspec.Struct, frozen=True):
    """An interval (s) in which a pair was not well clear (``end`` None: to the end)."""

    start: float
    end: float | None


# The encounter's signals that are the minimum over the pairs, and the sample field of each.
_MINIMA = (
    ("separation", "separation"),
    ("horizontal_separation", "horizontal"),
    ("vertical_separation", "vertical"),
    ("cpa_distance", "cpa_distance"),
    ("cpa_time", "cpa_time"),
)


def _pair_signals(pair: str) -> tuple[str, str]:
    """A pair's own signals (``alpha-bravo``: ``separation_alpha_bravo``, ``well_clear_...``)."""
    key = pair.replace("-", "_")
    return f"separation_{key}", f"well_clear_{key}"


def signal_names(vehicles: Sequence[str]) -> list[str]:
    """The signals [`Encounter.signals`][multicosim.fleet.results.Encounter.signals] gives a
    fleet of ``vehicles`` (names, in the fleet's order): what its requirements may read."""
    names = [column for column, _ in _MINIMA] + ["well_clear"]
    for a, b in pairs_of(vehicles):
        names += _pair_signals(pair_name(a, b))
    return names


class Encounter(msgspec.Struct, frozen=True, kw_only=True):
    """The fleet's pairs over the flight: per pair (``alpha-bravo``) its samples, closest
    approach and losses of well clear, and the collisions; ``well_clear`` names the volume
    judged. [`signals`][multicosim.fleet.results.Encounter.signals] gives them as a requirement
    reads them."""

    well_clear: str
    pairs: dict[str, list[PairSample]]
    closest: dict[str, Approach]
    losses: dict[str, list[LossOfWellClear]]
    collisions: list[VehicleCollision]

    def min_separation(self) -> float:
        """The smallest separation of any pair (inf without pairs)."""
        return min((a.separation for a in self.closest.values()), default=math.inf)

    def signals(self) -> dict[str, list[float]]:
        """Columns over the samples' times: ``separation``, ``horizontal_separation``,
        ``vertical_separation``, ``cpa_distance``, ``cpa_time`` (each the minimum over
        pairs), ``well_clear`` (1 while every pair is), and each pair's own
        (``separation_alpha_bravo``, ...)."""
        if not self.pairs:
            return {"time": []}
        series = list(self.pairs.items())
        times = [s.time for s in series[0][1]]
        out: dict[str, list[float]] = {"time": times}
        n = min(len(samples) for _, samples in series)
        for column, field in _MINIMA:
            out[column] = [min(getattr(s[i], field) for _, s in series) for i in range(n)]
        out["well_clear"] = [float(all(s[i].well_clear for _, s in series)) for i in range(n)]
        for name, samples in series:
            separation, well_clear = _pair_signals(name)
            out[separation] = [s.separation for s in samples[:n]]
            out[well_clear] = [float(s.well_clear) for s in samples[:n]]
        out["time"] = times[:n]
        return out


class FleetResult(msgspec.Struct, frozen=True, kw_only=True):
    """Each vehicle's [`MissionResult`][multicosim.mavlink.mission.MissionResult] by name, and the
    [`Encounter`][multicosim.fleet.results.Encounter]."""

    results: dict[str, MissionResult]
    encounter: Encounter

    @property
    def completed(self) -> bool:
        """Whether every vehicle's mission ran to its end."""
        return all(r.completed for r in self.results.values())


def pairs_of(names: Sequence[str]) -> list[tuple[str, str]]:
    """Every pair of ``names`` once, in the fleet's order."""
    return list(itertools.combinations(names, 2))


def losses(samples: Sequence[PairSample]) -> list[LossOfWellClear]:
    """The intervals in which ``samples`` were not well clear."""
    found: list[LossOfWellClear] = []
    start: float | None = None
    for s in samples:
        if not s.well_clear and start is None:
            start = s.time
        elif s.well_clear and start is not None:
            found.append(LossOfWellClear(start, s.time))
            start = None
    if start is not None:
        found.append(LossOfWellClear(start, None))
    return found


def closest(
    samples: Sequence[PairSample], midpoints: Mapping[float, tuple[float, float, float]]
) -> Approach:
    """The sample of least separation, where it happened."""
    best = min(samples, key=lambda s: s.separation)
    north, east, up = midpoints.get(best.time, (math.nan, math.nan, math.nan))
    return Approach(separation=best.separation, time=best.time, north=north, east=east, up=up)
