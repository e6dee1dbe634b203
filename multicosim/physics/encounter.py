"""Between vehicles: separation, the closest point of approach, well clear, collisions.

Vehicle-neutral geometry on true states (north/east/down metres from home and velocities),
what a fleet's requirements read ([`multicosim.fleet`][multicosim.fleet]):

* **separation**: the 3-D distance between two vehicles' bodies (their centres' distance less
  both body radii; negative when they overlap), with the centres' horizontal and vertical
  distances (as separation standards measure them);
* **closest point of approach** (CPA): where the current velocities take the two closest,
  and in how long (0 when they are already drawing apart);
* **well clear**: a [`WellClear`][multicosim.physics.encounter.WellClear] volume's predicate, with
  named presets whose sources the docs cite: RTCA DO-365's detect-and-avoid well-clear definition
  ([`DO_365`][multicosim.physics.encounter.DO_365]), the near mid-air collision volume
  ([`NMAC`][multicosim.physics.encounter.NMAC]) and ASTM F3442's small-UAS well clear
  ([`ASTM_F3442`][multicosim.physics.encounter.ASTM_F3442]);
* **collisions**: two bodies' spheres touching;
  [`first_contact`][multicosim.physics.encounter.first_contact] finds when, between two samples,
  from the velocities (the analytic way, at low fidelity; MuJoCo's contacts at medium and high).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import msgspec

from ..core.errors import ConfigurationError, check_number

__all__ = [
    "ASTM_F3442",
    "CONTACTS_TOPIC",
    "DO_365",
    "NMAC",
    "PRESETS",
    "Kinematics",
    "PairSample",
    "VehicleContact",
    "WellClear",
    "check_volume",
    "closest_approach",
    "first_contact",
    "pair_sample",
]

FT = 0.3048  # m


class WellClear(msgspec.Struct, frozen=True, kw_only=True):
    """A well-clear volume: lost where two aircraft are within ``horizontal`` metres (or will
    be, horizontally, within ``tau`` seconds by the modified-tau test, missing by at most
    ``miss`` metres) and within ``vertical`` metres of each other's altitude.

    ``tau`` 0 makes the horizontal test a plain distance (a fixed cylinder, as the near
    mid-air collision volume is). ``miss`` defaults to ``horizontal``.
    """

    horizontal: float
    vertical: float
    tau: float = 0.0
    miss: float | None = None
    name: str = "custom"

    def __post_init__(self) -> None:
        check_number("well_clear.horizontal", self.horizontal, 0.0, 1e6, open_lo=True)
        check_number("well_clear.vertical", self.vertical, 0.0, 1e6, open_lo=True)
        check_number("well_clear.tau", self.tau, 0.0, 3600.0)
        if self.miss is not None:
            check_number("well_clear.miss", self.miss, 0.0, 1e6)

    def lost(self, a: Kinematics, b: Kinematics) -> bool:
        """Whether ``a`` and ``b`` are not well clear of each other now."""
        dn, de = b.north - a.north, b.east - a.east
        vn, ve = b.vn - a.vn, b.ve - a.ve
        if abs(b.down - a.down) > self.vertical:
            return False
        r2 = dn * dn + de * de
        dmod2 = self.horizontal * self.horizontal
        if r2 <= dmod2:
            return True
        if self.tau <= 0.0:
            return False
        closing = dn * vn + de * ve  # r * dr/dt: negative while closing
        if closing >= 0.0:
            return False
        # DO-365's modified tau: time to within DMOD at the current closure rate.
        tau_mod = (dmod2 - r2) / closing
        if tau_mod > self.tau:
            return False
        v2 = vn * vn + ve * ve
        t = -closing / v2 if v2 > 0.0 else 0.0
        miss = math.hypot(dn + vn * t, de + ve * t)
        return miss <= (self.miss if self.miss is not None else self.horizontal)


DO_365 = WellClear(horizontal=4000 * FT, vertical=450 * FT, tau=35.0, miss=4000 * FT, name="DO-365")
"""RTCA DO-365 (Minimum Operational Performance Standards for Detect and Avoid, appendix C):
DMOD 4000 ft, HMD 4000 ft, ZTHR 450 ft, modified tau 35 s."""

NMAC = WellClear(horizontal=500 * FT, vertical=100 * FT, name="NMAC")
"""The near mid-air collision volume (DO-365, ICAO): within 500 ft horizontally and 100 ft
vertically."""

ASTM_F3442 = WellClear(horizontal=2000 * FT, vertical=250 * FT, name="ASTM F3442")
"""ASTM F3442/F3442M (detect and avoid for small unmanned aircraft): well clear is 2000 ft
horizontally and 250 ft vertically."""

PRESETS: dict[str, WellClear] = {p.name: p for p in (DO_365, NMAC, ASTM_F3442)}
"""The presets by name (what a case file names)."""


class Kinematics(NamedTuple):
    """A vehicle's true position (north/east/down metres from home) and velocity (m/s)."""

    north: float
    east: float
    down: float
    vn: float
    ve: float
    vd: float


def closest_approach(a: Kinematics, b: Kinematics) -> tuple[float, float]:
    """(time, distance) of the closest approach of the centres at the current velocities;
    time 0 (and the current distance) when they are not closing."""
    dn, de, dd = b.north - a.north, b.east - a.east, b.down - a.down
    vn, ve, vd = b.vn - a.vn, b.ve - a.ve, b.vd - a.vd
    v2 = vn * vn + ve * ve + vd * vd
    t = -(dn * vn + de * ve + dd * vd) / v2 if v2 > 0.0 else 0.0
    t = max(t, 0.0)
    return t, math.sqrt((dn + vn * t) ** 2 + (de + ve * t) ** 2 + (dd + vd * t) ** 2)


def first_contact(a: Kinematics, b: Kinematics, reach: float, within: float) -> float | None:
    """When, within ``within`` seconds at the current velocities, the centres come within
    ``reach`` (both radii) of each other: 0 if they already are, None if not."""
    dn, de, dd = b.north - a.north, b.east - a.east, b.down - a.down
    vn, ve, vd = b.vn - a.vn, b.ve - a.ve, b.vd - a.vd
    c = dn * dn + de * de + dd * dd - reach * reach
    if c <= 0.0:
        return 0.0
    qa = vn * vn + ve * ve + vd * vd
    qb = 2.0 * (dn * vn + de * ve + dd * vd)
    disc = qb * qb - 4.0 * qa * c
    if qa == 0.0 or qb >= 0.0 or disc < 0.0:
        return None
    t = (-qb - math.sqrt(disc)) / (2.0 * qa)
    return t if t <= within else None


CONTACTS_TOPIC = "mcs/contacts"
"""Where a world of several vehicles publishes their contacts
([`VehicleContact`][multicosim.physics.encounter.VehicleContact])."""


class VehicleContact(msgspec.Struct, frozen=True):
    """Vehicles ``a`` and ``b``'s bodies began to touch at ``time`` (s), closing at ``speed``
    (m/s): what MuJoCo's contacts say, published by the world on ``CONTACTS_TOPIC``."""

    a: str
    b: str
    time: float
    speed: float


class PairSample(msgspec.Struct, frozen=True):
    """Two vehicles at one instant: ``separation`` of their bodies (m), the centres'
    ``horizontal`` and ``vertical`` distances, their ``closing`` speed (m/s, + closing), the
    closest approach ahead (``cpa_time`` s, ``cpa_distance`` m between the centres) and
    whether they are ``well_clear``."""

    time: float
    separation: float
    horizontal: float
    vertical: float
    closing: float
    cpa_time: float
    cpa_distance: float
    well_clear: bool


def pair_sample(
    time: float, a: Kinematics, b: Kinematics, reach: float, volume: WellClear
) -> PairSample:
    """The pair's sample at ``time`` (``reach``: both body radii)."""
    dn, de, dd = b.north - a.north, b.east - a.east, b.down - a.down
    distance = math.sqrt(dn * dn + de * de + dd * dd)
    vn, ve, vd = b.vn - a.vn, b.ve - a.ve, b.vd - a.vd
    closing = -(dn * vn + de * ve + dd * vd) / distance if distance > 0.0 else 0.0
    cpa_time, cpa_distance = closest_approach(a, b)
    return PairSample(
        time=time,
        separation=distance - reach,
        horizontal=math.hypot(dn, de),
        vertical=abs(dd),
        closing=closing,
        cpa_time=cpa_time,
        cpa_distance=cpa_distance,
        well_clear=not volume.lost(a, b),
    )


def check_volume(volume: object) -> WellClear:
    """``volume`` as a WellClear: one, or a preset's name (ConfigurationError naming them)."""
    if isinstance(volume, WellClear):
        return volume
    if isinstance(volume, str) and volume in PRESETS:
        return PRESETS[volume]
    raise ConfigurationError(
        "well_clear", volume, f"a physics.WellClear or a preset: {', '.join(PRESETS)}"
    )
