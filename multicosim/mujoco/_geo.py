"""Local ENU coordinates to latitude/longitude/altitude and back, around a home position.

The projection is the azimuthal equidistant one on a spherical Earth that PX4 uses for its
local frame (``map_projection``), so a GPS fix built here agrees with what PX4 would compute.
"""

from __future__ import annotations

import math

__all__ = ["EARTH_RADIUS", "geodetic_to_local", "local_to_geodetic"]

EARTH_RADIUS = 6_371_000.0  # metres, the sphere PX4's map projection uses


def local_to_geodetic(
    home: tuple[float, float, float], east: float, north: float, up: float
) -> tuple[float, float, float]:
    """(latitude, longitude, altitude) of the point ``east, north, up`` metres from ``home``."""
    lat0, lon0, alt0 = math.radians(home[0]), math.radians(home[1]), home[2]
    x = north / EARTH_RADIUS
    y = east / EARTH_RADIUS
    c = math.hypot(x, y)
    if c == 0.0:
        return home[0], home[1], alt0 + up
    sin_c, cos_c = math.sin(c), math.cos(c)
    sin_lat0, cos_lat0 = math.sin(lat0), math.cos(lat0)
    lat = math.asin(cos_c * sin_lat0 + x * sin_c * cos_lat0 / c)
    lon = lon0 + math.atan2(y * sin_c, c * cos_lat0 * cos_c - x * sin_lat0 * sin_c)
    return math.degrees(lat), math.degrees(lon), alt0 + up


def geodetic_to_local(
    home: tuple[float, float, float], latitude: float, longitude: float, altitude: float
) -> tuple[float, float, float]:
    """(east, north, up) metres of a geodetic position relative to ``home``."""
    lat0, lon0 = math.radians(home[0]), math.radians(home[1])
    lat, lon = math.radians(latitude), math.radians(longitude)
    sin_lat0, cos_lat0 = math.sin(lat0), math.cos(lat0)
    sin_lat, cos_lat = math.sin(lat), math.cos(lat)
    cos_dlon = math.cos(lon - lon0)
    arg = max(-1.0, min(1.0, sin_lat0 * sin_lat + cos_lat0 * cos_lat * cos_dlon))
    c = math.acos(arg)
    k = c / math.sin(c) if c != 0.0 else 1.0
    north = k * (cos_lat0 * sin_lat - sin_lat0 * cos_lat * cos_dlon) * EARTH_RADIUS
    east = k * cos_lat * math.sin(lon - lon0) * EARTH_RADIUS
    return east, north, altitude - home[2]
