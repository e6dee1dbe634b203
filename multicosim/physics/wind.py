"""Wind in the world: a steady wind, discrete gusts and Dryden turbulence, and the drag it causes.

The wind is the air's velocity; a vehicle feels it through its drag,
``F = 1/2 rho Cd A |v_air - v| (v_air - v)`` with the drag coefficient and area its
[`Body`][multicosim.physics.wind.Body] gives (the world knows no vehicle: the vehicle describes
itself). Every fidelity flies in the same air: MuJoCo applies the force to the vehicle's body, the
low-fidelity point mass adds it to its motion; real autopilots feel it through the world only.

Turbulence is the Dryden model of MIL-F-8785C at low altitude (MIL-HDBK-1797 gives the same):
for an altitude ``h`` (ft, held in 10..1000 ft) and ``W20`` the wind speed at 20 ft,

* length scales ``L_w = h``, ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2``;
* intensities ``sigma_w = 0.1 W20``, ``sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4``;
* longitudinal ``H_u(s) = sigma_u sqrt(2 L_u / (pi V)) / (1 + L_u s / V)``, lateral and vertical
  ``H(s) = sigma sqrt(L / (pi V)) (1 + sqrt(3) L s / V) / (1 + L s / V)^2``.

The filters are discretised exactly for the world's period (the first-order one as a
Gauss-Markov process, the second-order ones by their transition matrix and noise covariance),
so each component's standard deviation is its ``sigma`` at every step size. ``V`` is the mean
wind speed (at least 1 m/s): the turbulence is a frozen field carried past the vehicle by the
mean wind, which suits a hovering multicopter. The noise comes from a generator seeded from
the run's seed, so a seed gives the same turbulence.
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import msgspec
import numpy as np

from ..core.errors import ConfigurationError, check_number
from ..runtime.context import derive_seed

__all__ = [
    "AIR_DENSITY",
    "LIGHT",
    "MODERATE",
    "SEVERE",
    "Body",
    "DrydenTurbulence",
    "Gust",
    "Wind",
    "WindField",
    "drag_force",
    "wind_generator",
]

AIR_DENSITY = 1.225  # kg/m^3, ISA sea level
KNOT = 0.514444  # m/s
FOOT = 0.3048  # m
LIGHT = 15 * KNOT
"""``Wind.turbulence`` of MIL-F-8785C's light turbulence (W20 = 15 kt)."""
MODERATE = 30 * KNOT
"""``Wind.turbulence`` of moderate turbulence (W20 = 30 kt)."""
SEVERE = 45 * KNOT
"""``Wind.turbulence`` of severe turbulence (W20 = 45 kt)."""
MIN_DRYDEN_SPEED = 1.0  # m/s: the turbulence's advection speed when the mean wind is calmer
MAX_WIND = 100.0  # m/s


class Gust(msgspec.Struct, frozen=True, kw_only=True):
    """A discrete gust of the 1-cosine shape: from ``start`` (simulated seconds since the world
    started) it rises to ``speed`` (m/s) and falls back to 0 over ``duration`` (s), blowing
    from ``direction`` (degrees clockwise from north)."""

    start: float
    duration: float
    speed: float
    direction: float = 0.0

    def __post_init__(self) -> None:
        check_number("gust.start", self.start, 0.0, 1e6)
        check_number("gust.duration", self.duration, 0.0, 1e4, open_lo=True)
        check_number("gust.speed", self.speed, 0.0, MAX_WIND)
        check_number("gust.direction", self.direction, -360.0, 360.0)


class Wind(msgspec.Struct, frozen=True, kw_only=True):
    """The world's wind: steady ``speed`` (m/s) from ``direction`` (degrees clockwise from
    north, where it blows from, as weather reports give it), ``gusts`` and Dryden
    ``turbulence`` (``W20``, the wind speed at 20 ft that sets its intensity, m/s: 0 for none,
    [`LIGHT`][multicosim.physics.wind.LIGHT], [`MODERATE`][multicosim.physics.wind.MODERATE],
    [`SEVERE`][multicosim.physics.wind.SEVERE])."""

    speed: float = 0.0
    direction: float = 0.0
    gusts: tuple[Gust, ...] = ()
    turbulence: float = 0.0

    def __post_init__(self) -> None:
        check_number("wind.speed", self.speed, 0.0, MAX_WIND)
        check_number("wind.direction", self.direction, -360.0, 360.0)
        check_number("wind.turbulence", self.turbulence, 0.0, MAX_WIND)
        if not isinstance(self.gusts, tuple | list) or not all(
            isinstance(g, Gust) for g in self.gusts
        ):
            raise ConfigurationError("wind.gusts", self.gusts, "a sequence of physics.Gust")
        msgspec.structs.force_setattr(self, "gusts", tuple(self.gusts))


class Body(NamedTuple):
    """How the world sees a vehicle's body: the MuJoCo body ``name``, the ``radius`` (m) of
    the sphere that encloses it (for obstacles and clearances), its drag coefficient and
    reference area (m^2)."""

    name: str
    radius: float
    drag_coefficient: float
    drag_area: float


def drag_force(
    body: Body, air: tuple[float, float, float], velocity: tuple[float, float, float]
) -> tuple[float, float, float]:
    """The drag (N) on ``body`` moving at ``velocity`` in air moving at ``air`` (same frame)."""
    rx, ry, rz = air[0] - velocity[0], air[1] - velocity[1], air[2] - velocity[2]
    k = (
        0.5
        * AIR_DENSITY
        * body.drag_coefficient
        * body.drag_area
        * math.sqrt(rx * rx + ry * ry + rz * rz)
    )
    return (k * rx, k * ry, k * rz)


class _Scales(NamedTuple):
    sigma_u: float
    sigma_w: float
    length_u: float
    length_w: float


def dryden_scales(altitude: float, w20: float) -> _Scales:
    """MIL-F-8785C's low-altitude intensities (m/s) and length scales (m) at ``altitude`` m."""
    h = min(max(altitude / FOOT, 10.0), 1000.0)
    base = 0.177 + 0.000823 * h
    sigma_w = 0.1 * w20
    return _Scales(sigma_w / base**0.4, sigma_w, h / base**1.2 * FOOT, h * FOOT)


Mat2 = tuple[float, float, float, float]  # row-major 2x2


def _apply(m: Mat2, x: float, y: float) -> tuple[float, float]:
    return (m[0] * x + m[1] * y, m[2] * x + m[3] * y)


def _flat(m: Any) -> Mat2:
    return (float(m[0, 0]), float(m[0, 1]), float(m[1, 0]), float(m[1, 1]))


class _SecondOrder:
    """``sigma (1 + sqrt(3) T s) / (1 + T s)^2`` shaped noise, discretised exactly for ``dt``.

    NumPy sets it up; a step is scalar math (it runs every physics period).
    """

    def __init__(self, sigma: float, tau: float, dt: float) -> None:
        a = dt / tau
        ad = math.exp(-a) * np.array([[1.0 + a, dt], [-a / tau, 1.0 - a]])
        # Noise covariance of one step: the integral of e^{As} B B^T e^{A^T s} over [0, dt].
        s = np.linspace(0.0, dt, 33)
        g = np.exp(-s / tau) * np.array([s, 1.0 - s / tau])
        qd = np.trapezoid(g[:, None, :] * g[None, :, :], s, axis=2)
        # The stationary covariance P = Ad P Ad^T + Qd; scale the output to sigma exactly.
        p = np.linalg.solve(np.eye(4) - np.kron(ad, ad), qd.reshape(4)).reshape(2, 2)
        c = np.array([1.0, math.sqrt(3.0) * tau])
        gain = sigma / math.sqrt(float(c @ p @ c)) if sigma > 0 else 0.0
        self.ad = _flat(ad)
        self.chol = _flat(np.linalg.cholesky(qd + 1e-18 * np.eye(2)))
        self.p_chol = _flat(np.linalg.cholesky(p + 1e-18 * np.eye(2)))
        self.c = (gain * float(c[0]), gain * float(c[1]))


_Filters = tuple[float, float, float, _SecondOrder, _SecondOrder]


@functools.lru_cache(maxsize=4096)
def _filters(w20: float, speed: float, dt: float, altitude: int) -> _Filters:
    """The three filters at a whole-metre ``altitude`` (shared by runs: setting up costs)."""
    sc = dryden_scales(float(altitude), w20)
    decay = math.exp(-speed * dt / sc.length_u)
    return (
        sc.sigma_u,
        decay,
        math.sqrt(1.0 - decay * decay),
        _SecondOrder(sc.sigma_u, sc.length_u / speed, dt),
        _SecondOrder(sc.sigma_w, sc.length_w / speed, dt),
    )


class DrydenTurbulence:
    """Dryden turbulence sampled every ``dt`` s: (longitudinal, lateral, vertical) m/s.

    ``w20`` sets the intensity, ``speed`` (m/s) the advection speed ``V``; ``rng`` draws
    the noise (five normal variates a step, drawn in blocks, in a fixed order).
    """

    def __init__(self, w20: float, speed: float, dt: float, rng: np.random.Generator) -> None:
        self.w20 = w20
        self.speed = max(speed, MIN_DRYDEN_SPEED)
        self.dt = dt
        self.rng = rng
        self._filters: dict[int, _Filters] = {}
        self._u: float | None = None
        self._v = (0.0, 0.0)
        self._w = (0.0, 0.0)
        self._normals: list[float] = []
        self._next = 0

    def step(self, altitude: float) -> tuple[float, float, float]:
        """The next sample at ``altitude`` (m above home)."""
        # This runs every period: the filters' lookup and the draw are written out here.
        key = round(altitude)
        f = self._filters.get(key)
        if f is None:
            f = self._filters[key] = _filters(self.w20, self.speed, self.dt, key)
        sigma_u, decay, kick, lateral, vertical = f
        i = self._next
        if i + 5 > len(self._normals):
            self._normals = self.rng.standard_normal(5 * 1024).tolist()
            i = 0
        self._next = i + 5
        n0, n1, n2, n3, n4 = self._normals[i : i + 5]
        if self._u is None:
            # Start from the stationary distribution: the statistics hold from the first step.
            self._u = sigma_u * n0
            self._v = _apply(lateral.p_chol, n1, n2)
            self._w = _apply(vertical.p_chol, n3, n4)
        else:
            # The state's transition plus the step's noise: ``Ad x + chol n`` of each filter.
            self._u = decay * self._u + sigma_u * kick * n0
            v0, v1 = self._v
            a, c = lateral.ad, lateral.chol
            self._v = (
                (a[0] * v0 + a[1] * v1) + (c[0] * n1 + c[1] * n2),
                (a[2] * v0 + a[3] * v1) + (c[2] * n1 + c[3] * n2),
            )
            w0, w1 = self._w
            a, c = vertical.ad, vertical.chol
            self._w = (
                (a[0] * w0 + a[1] * w1) + (c[0] * n3 + c[1] * n4),
                (a[2] * w0 + a[3] * w1) + (c[2] * n3 + c[3] * n4),
            )
        v0, v1 = self._v
        w0, w1 = self._w
        lc, vc = lateral.c, vertical.c
        return (self._u, lc[0] * v0 + lc[1] * v1, vc[0] * w0 + vc[1] * w1)


def wind_generator(seed: int) -> np.random.Generator:
    """The turbulence's generator for a component's ``seed`` (apart from its sensor noise)."""
    return np.random.default_rng(derive_seed(seed, "wind"))


class WindField:
    """The air's velocity (north, east, up; m/s) over simulated time, stepped once a period."""

    def __init__(self, wind: Wind, dt: float, rng: np.random.Generator) -> None:
        self.wind = wind
        d = math.radians(wind.direction)
        # Blowing from ``direction``: the air moves the opposite way.
        self._downwind = (-math.cos(d), -math.sin(d))
        self._steady = (wind.speed * self._downwind[0], wind.speed * self._downwind[1])
        self._turbulence = (
            DrydenTurbulence(wind.turbulence, wind.speed, dt, rng) if wind.turbulence else None
        )

    def step(self, time: float, altitude: float) -> tuple[float, float, float]:
        """The wind at ``time`` (s) for a vehicle ``altitude`` m above home."""
        north, east = self._steady
        up = 0.0
        for g in self.wind.gusts:
            phase = (time - g.start) / g.duration
            if 0.0 <= phase <= 1.0:
                speed = 0.5 * g.speed * (1.0 - math.cos(2.0 * math.pi * phase))
                d = math.radians(g.direction)
                north -= speed * math.cos(d)
                east -= speed * math.sin(d)
        if self._turbulence is not None:
            u, v, w = self._turbulence.step(altitude)
            dn, de = self._downwind
            # u along the mean wind, v to its right (seen from above), w up.
            north += u * dn - v * de
            east += u * de + v * dn
            up += w
        return (north, east, up)
