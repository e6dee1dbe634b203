"""Geographic coordinates around a home position, and attitudes: one place for every vehicle.

**The convention of multicosim's public API.** A local position is metres **north, east,
up** of home (the vehicle's start), always passed and returned by name (``north=``,
``east=``, ``up=``; [`NorthEast`][multicosim.core.geo.NorthEast],
``FlightSample.north``/``east``/``up``), so that a wrong order cannot pass silently; a yaw (heading)
is in degrees clockwise from north. Attack offsets on positions are given the same way
(``multicosim.attacks.Local``). Other orders appear only where something outside dictates them, and
there by name too: MAVLink's north-east-down (``FlightSample.x/y/z``, PX4's and ArduPilot's
messages), MuJoCo's and Foxglove's east-north-up (the worlds' frames,
[`local_to_geodetic`][multicosim.core.geo.local_to_geodetic]).

The local frame is PX4's (``map_projection``): the azimuthal equidistant projection on a
spherical Earth, so a GPS fix built by a world agrees with what PX4 (and our autopilot)
compute from it. Worlds, autopilots, attack models and tests all project with
[`LocalProjection`][multicosim.core.geo.LocalProjection]; the ENU helpers are the same projection
with axes swapped.

Attitudes are unit quaternions ``(w, x, y, z)`` rotating body axes into the local frame.
Two conventions meet here: robotics' (MuJoCo, Foxglove, the rover: body forward-left-up in
east-north-up) and aerospace's (PX4, ArduPilot: forward-right-down in north-east-down);
[`swap_attitude_frames`][multicosim.core.geo.swap_attitude_frames] converts between them.

Scalar math only: this runs in the worlds' and the estimator's hot loops.
"""

from __future__ import annotations

import math
from typing import NamedTuple

__all__ = [
    "EARTH_RADIUS",
    "GRAVITY",
    "EastNorthUp",
    "Home",
    "LocalProjection",
    "NorthEast",
    "Quaternion",
    "geodetic_to_local",
    "local_to_geodetic",
    "pressure_altitude",
    "pressure_hpa",
    "quaternion_from_euler",
    "quaternion_multiply",
    "rotate_to_body",
    "swap_attitude_frames",
]

Quaternion = tuple[float, float, float, float]
"""A unit quaternion ``(w, x, y, z)``."""

EARTH_RADIUS = 6_371_000.0
"""Metres: the sphere of PX4's map projection (``CONSTANTS_RADIUS_OF_EARTH``)."""

GRAVITY = 9.80665
"""m/s²: standard gravity, PX4's ``CONSTANTS_ONE_G``; every world integrates with it."""


class Home(NamedTuple):
    """Where a local frame's origin is: WGS84 latitude, longitude (degrees), altitude (m AMSL).

    The default is PX4 SITL's home (``PX4_HOME_LAT/LON/ALT``, Zurich), so that a world and
    PX4 agree on where "here" is.
    """

    lat: float = 47.397742
    lon: float = 8.545594
    alt: float = 488.0


class NorthEast(NamedTuple):
    """A horizontal local position: metres north and east of a reference point."""

    north: float
    east: float


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

    def project(self, lat: float, lon: float) -> NorthEast:
        """North and east (m) of ``lat, lon`` from the reference, by name (``.north``)."""
        la = math.radians(lat)
        dlon = math.radians(lon) - self._lon0
        sin_lat, cos_lat, cos_dlon = math.sin(la), math.cos(la), math.cos(dlon)
        arg = self._sin0 * sin_lat + self._cos0 * cos_lat * cos_dlon
        c = math.acos(max(-1.0, min(1.0, arg)))
        k = c / math.sin(c) if abs(c) > 1e-12 else 1.0
        north = k * (self._cos0 * sin_lat - self._sin0 * cos_lat * cos_dlon) * EARTH_RADIUS
        east = k * cos_lat * math.sin(dlon) * EARTH_RADIUS
        return NorthEast(north, east)

    def reproject(self, north: float, east: float) -> tuple[float, float]:
        """Latitude and longitude (degrees) of the point ``north, east`` (m) from the reference."""
        x, y = north / EARTH_RADIUS, east / EARTH_RADIUS
        c = math.sqrt(x * x + y * y)
        if c == 0.0:
            return self.lat, self.lon
        # sin(c)/c is exact down to the smallest c: micrometres from home are not home.
        cos_c, sinc = math.cos(c), math.sin(c) / c
        lat = math.asin(cos_c * self._sin0 + x * sinc * self._cos0)
        lon = self._lon0 + math.atan2(y * sinc, self._cos0 * cos_c - x * self._sin0 * sinc)
        return math.degrees(lat), math.degrees(lon)


class EastNorthUp(NamedTuple):
    """A point of a world's east-north-up frame (MuJoCo's, Foxglove's): metres from home."""

    east: float
    north: float
    up: float


def local_to_geodetic(
    home: tuple[float, float, float], *, east: float, north: float, up: float
) -> tuple[float, float, float]:
    """(latitude, longitude, altitude) of the point ``east, north, up`` metres from ``home``."""
    lat, lon = LocalProjection.at(home).reproject(north, east)
    return lat, lon, home[2] + up


def geodetic_to_local(
    home: tuple[float, float, float], latitude: float, longitude: float, altitude: float
) -> EastNorthUp:
    """Metres east, north and up (by name) of a geodetic position relative to ``home``."""
    north, east = LocalProjection.at(home).project(latitude, longitude)
    return EastNorthUp(east=east, north=north, up=altitude - home[2])


def pressure_hpa(altitude_amsl: float) -> float:
    """Static pressure (hPa) at ``altitude_amsl`` metres in the ISA troposphere."""
    return float(1013.25 * (1.0 - 2.25577e-5 * altitude_amsl) ** 5.25588)


def pressure_altitude(hpa: float) -> float:
    """ISA altitude (m) at which the static pressure is ``hpa``."""
    return float((1.0 - (hpa / 1013.25) ** (1.0 / 5.25588)) / 2.25577e-5)


# -- attitudes --------------------------------------------------------------------------------


def quaternion_multiply(a: tuple[float, ...], b: tuple[float, ...]) -> Quaternion:
    """The Hamilton product ``a * b`` (rotate by ``b``, then by ``a``)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def quaternion_from_euler(roll: float, pitch: float, yaw: float) -> Quaternion:
    """The unit quaternion of ZYX Euler angles (yaw, then pitch, then roll; radians)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )


def rotate_to_body(
    q: tuple[float, ...], v: tuple[float, float, float]
) -> tuple[float, float, float]:
    """``v`` (in the local frame) expressed in the body frame of attitude ``q``."""
    w, x, y, z = q
    vx, vy, vz = v
    # R^T v for the rotation matrix R of q (body to local).
    return (
        (1 - 2 * (y * y + z * z)) * vx + 2 * (x * y + w * z) * vy + 2 * (x * z - w * y) * vz,
        2 * (x * y - w * z) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z + w * x) * vz,
        2 * (x * z + w * y) * vx + 2 * (y * z - w * x) * vy + (1 - 2 * (x * x + y * y)) * vz,
    )


_H = math.sqrt(0.5)
_NED_ENU = (0.0, _H, _H, 0.0)  # a half turn about (1, 1, 0)/sqrt(2): swaps NED and ENU
_FLU_FRD = (0.0, 1.0, 0.0, 0.0)  # a half turn about x: swaps FLU and FRD


def swap_attitude_frames(q: tuple[float, ...]) -> Quaternion:
    """An attitude of a FLU body in ENU as a FRD body in NED, or the other way round.

    Both frame changes are half turns, each its own inverse, so one function serves both
    directions (MuJoCo to PX4, PX4 to Foxglove).
    """
    return quaternion_multiply(quaternion_multiply(_NED_ENU, q), _FLU_FRD)
