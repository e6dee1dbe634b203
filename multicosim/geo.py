"""Geographic coordinates around a home position: one projection for every vehicle.

The local frame is PX4's (``map_projection``): the azimuthal equidistant projection on a
spherical Earth, so a GPS fix built by a world agrees with what PX4 (and our autopilot)
compute from it. Worlds, autopilots, attack models and tests all project with
:class:`LocalProjection`; the ENU helpers are the same projection with axes swapped.

Scalar math only: this runs in the worlds' and the estimator's hot loops.
"""

from __future__ import annotations

import math
from typing import NamedTuple

__all__ = [
    "EARTH_RADIUS",
    "Home",
    "LocalProjection",
    "geodetic_to_local",
    "local_to_geodetic",
    "pressure_altitude",
    "pressure_hpa",
]

EARTH_RADIUS = 6_371_000.0
"""Metres: the sphere of PX4's map projection (``CONSTANTS_RADIUS_OF_EARTH``)."""


class Home(NamedTuple):
    """Where a local frame's origin is: WGS84 latitude, longitude (degrees), altitude (m AMSL).

    The default is PX4 SITL's home (``PX4_HOME_LAT/LON/ALT``, Zurich), so that a world and
    PX4 agree on where "here" is.
    """

    lat: float = 47.397742
    lon: float = 8.545594
    alt: float = 488.0


class LocalProjection:
    """Projects latitude/longitude (degrees) to north/east metres around a reference point."""

    __slots__ = ("_cos0", "_lat0", "_lon0", "_sin0", "lat", "lon")

    def __init__(self, lat: float, lon: float) -> None:
        self.lat = lat
        self.lon = lon
        self._lat0 = math.radians(lat)
        self._lon0 = math.radians(lon)
        self._sin0 = math.sin(self._lat0)
        self._cos0 = math.cos(self._lat0)

    @classmethod
    def at(cls, home: tuple[float, float, float] | tuple[float, float]) -> LocalProjection:
        """The projection around ``home`` (latitude, longitude[, altitude])."""
        return cls(home[0], home[1])

    def project(self, lat: float, lon: float) -> tuple[float, float]:
        """North and east (m) of ``lat, lon`` from the reference."""
        la = math.radians(lat)
        dlon = math.radians(lon) - self._lon0
        sin_lat, cos_lat, cos_dlon = math.sin(la), math.cos(la), math.cos(dlon)
        arg = self._sin0 * sin_lat + self._cos0 * cos_lat * cos_dlon
        c = math.acos(max(-1.0, min(1.0, arg)))
        k = c / math.sin(c) if abs(c) > 1e-12 else 1.0
        north = k * (self._cos0 * sin_lat - self._sin0 * cos_lat * cos_dlon) * EARTH_RADIUS
        east = k * cos_lat * math.sin(dlon) * EARTH_RADIUS
        return north, east

    def reproject(self, north: float, east: float) -> tuple[float, float]:
        """Latitude and longitude (degrees) of the point ``north, east`` (m) from the reference."""
        x, y = north / EARTH_RADIUS, east / EARTH_RADIUS
        c = math.sqrt(x * x + y * y)
        if c < 1e-12:
            return self.lat, self.lon
        sin_c, cos_c = math.sin(c), math.cos(c)
        lat = math.asin(cos_c * self._sin0 + x * sin_c * self._cos0 / c)
        lon = self._lon0 + math.atan2(y * sin_c, c * self._cos0 * cos_c - x * self._sin0 * sin_c)
        return math.degrees(lat), math.degrees(lon)


def local_to_geodetic(
    home: tuple[float, float, float], east: float, north: float, up: float
) -> tuple[float, float, float]:
    """(latitude, longitude, altitude) of the point ``east, north, up`` metres from ``home``."""
    lat, lon = LocalProjection.at(home).reproject(north, east)
    return lat, lon, home[2] + up


def geodetic_to_local(
    home: tuple[float, float, float], latitude: float, longitude: float, altitude: float
) -> tuple[float, float, float]:
    """(east, north, up) metres of a geodetic position relative to ``home``."""
    north, east = LocalProjection.at(home).project(latitude, longitude)
    return east, north, altitude - home[2]


def pressure_hpa(altitude_amsl: float) -> float:
    """Static pressure (hPa) at ``altitude_amsl`` metres in the ISA troposphere."""
    return float(1013.25 * (1.0 - 2.25577e-5 * altitude_amsl) ** 5.25588)


def pressure_altitude(hpa: float) -> float:
    """ISA altitude (m) at which the static pressure is ``hpa``."""
    return float((1.0 - (hpa / 1013.25) ** (1.0 / 5.25588)) / 2.25577e-5)
