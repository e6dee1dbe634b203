"""The encounter monitor: a participant beside the vehicles that measures every pair.

It reads each vehicle's ground truth (``Truth``) every period,
takes a [`PairSample`][multicosim.physics.encounter.PairSample] of every pair (published on
``mcs/encounter/<a>/<b>``, for traces), and records
collisions: from MuJoCo's contacts where the world reports them (two quadrotors at medium and
high fidelity), else analytically, when two bodies' spheres come to touch between two samples
at the velocities they had (low fidelity, where each vehicle flies a world of its own; a
rover, whose body has no contact sphere).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING

from ..mavlink.hil import Truth
from ..physics.encounter import (
    CONTACTS_TOPIC,
    Kinematics,
    PairSample,
    VehicleContact,
    WellClear,
    first_contact,
    pair_sample,
)
from ..trace import ENCOUNTER_CHANNEL
from .results import Encounter, VehicleCollision, closest, losses, pair_name, pairs_of

if TYPE_CHECKING:
    from ..runtime.context import StepContext, Subscription

__all__ = ["EncounterMonitor", "pair_topic"]


class EncounterMonitor:
    """Samples every pair of ``truths`` (vehicle name -> truth topic) each ``period``.

    ``radii`` are the bodies' radii (m); ``volume`` the well-clear volume judged. A pair of
    two ``touching`` vehicles (those whose contacts with each other the world reports) has
    its collisions from those contacts; any other pair's are found from the states.
    """

    def __init__(
        self,
        truths: Mapping[str, str],
        radii: Mapping[str, float],
        volume: WellClear,
        period: float,
        *,
        touching: Collection[str] = (),
    ) -> None:
        self.period = period
        self.truths = dict(truths)
        self.radii = dict(radii)
        self.volume = volume
        self.touching = frozenset(touching)
        self.pairs = pairs_of(list(truths))
        self.samples: dict[str, list[PairSample]] = {pair_name(a, b): [] for a, b in self.pairs}
        self.midpoints: dict[str, dict[float, tuple[float, float, float]]] = {
            pair_name(a, b): {} for a, b in self.pairs
        }
        self.collisions: list[VehicleCollision] = []
        self._subs: dict[str, Subscription[Truth]] = {}
        self._contacts: Subscription[VehicleContact] | None = None
        self._last: dict[str, Kinematics] = {}
        self._last_time = 0.0
        self._touching: set[tuple[str, str]] = set()

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to every truth (and to the world's contacts)."""
        for name, topic in self.truths.items():
            self._subs[name] = ctx.subscribe(topic, Truth)
        self._contacts = ctx.subscribe(CONTACTS_TOPIC, VehicleContact)

    def _state(self, name: str, time: float) -> Kinematics | None:
        truth = self._subs[name].latest
        if truth is None:
            return None
        # Held from its stamp to now at its velocity (samples of one instant need none).
        dt = time - truth.time
        return Kinematics(
            truth.north + truth.vn * dt,
            truth.east + truth.ve * dt,
            truth.down + truth.vd * dt,
            truth.vn,
            truth.ve,
            truth.vd,
        )

    def step(self, ctx: StepContext) -> None:
        """Sample every pair; record the collisions that began."""
        time = ctx.time
        assert self._contacts is not None
        for contact in self._contacts.messages:
            self.collisions.append(
                VehicleCollision(
                    a=contact.a,
                    b=contact.b,
                    time=contact.time,
                    speed=contact.speed,
                    source="contact",
                )
            )
        states = {name: self._state(name, time) for name in self.truths}
        for a, b in self.pairs:
            sa, sb = states[a], states[b]
            if sa is None or sb is None:
                continue
            reach = self.radii.get(a, 0.0) + self.radii.get(b, 0.0)
            name = pair_name(a, b)
            sample = pair_sample(time, sa, sb, reach, self.volume)
            self.samples[name].append(sample)
            ctx.publish(pair_topic(a, b), sample)  # for traces and their plots
            self.midpoints[name][time] = (
                (sa.north + sb.north) / 2,
                (sa.east + sb.east) / 2,
                -(sa.down + sb.down) / 2,
            )
            if a not in self.touching or b not in self.touching:
                self._analytic(a, b, sa, sb, reach, time)
        self._last = {n: s for n, s in states.items() if s is not None}
        self._last_time = time

    def _analytic(
        self, a: str, b: str, sa: Kinematics, sb: Kinematics, reach: float, time: float
    ) -> None:
        la, lb = self._last.get(a), self._last.get(b)
        touching = first_contact(sa, sb, reach, 0.0) is not None
        if la is not None and lb is not None and (a, b) not in self._touching:
            since = time - self._last_time
            when = first_contact(la, lb, reach, since)
            if when is None and touching:
                when = since  # touching now, not by the straight lines: at this sample
            if when is not None:
                speed = _closing(la, lb)
                self.collisions.append(
                    VehicleCollision(a=a, b=b, time=self._last_time + when, speed=speed)
                )
        if touching:
            self._touching.add((a, b))
        else:
            self._touching.discard((a, b))

    def encounter(self) -> Encounter:
        """What was measured so far."""
        return Encounter(
            well_clear=self.volume.name,
            pairs={n: list(s) for n, s in self.samples.items()},
            closest={n: closest(s, self.midpoints[n]) for n, s in self.samples.items() if s},
            losses={n: losses(s) for n, s in self.samples.items()},
            collisions=list(self.collisions),
        )


def pair_topic(a: str, b: str) -> str:
    """Where the monitor publishes the samples of vehicles ``a`` and ``b``."""
    return f"{ENCOUNTER_CHANNEL}/{a}/{b}"


def _closing(a: Kinematics, b: Kinematics) -> float:
    """The speed at which ``a`` and ``b`` close (m/s; their relative speed along the line)."""
    dn, de, dd = b.north - a.north, b.east - a.east, b.down - a.down
    vn, ve, vd = b.vn - a.vn, b.ve - a.ve, b.vd - a.vd
    distance = math.sqrt(dn * dn + de * de + dd * dd)
    if distance == 0.0:
        return math.sqrt(vn * vn + ve * ve + vd * vd)
    return max(0.0, -(dn * vn + de * ve + dd * vd) / distance)
