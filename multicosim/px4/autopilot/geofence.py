"""The geofence a ground station uploads: polygons and circles that include or exclude.

A point is inside the fence as PX4 judges it: inside at least one inclusion polygon or
circle (when there is any) and outside every exclusion. Polygons arrive as runs of vertex
items, each carrying its polygon's vertex count in param 1; circles carry their radius.
"""

from __future__ import annotations

import math

from ...core.geo import LocalProjection
from ...mavlink.dialect import (
    CMD_FENCE_CIRCLE_INCLUSION,
    CMD_FENCE_POLYGON_EXCLUSION,
    CMD_FENCE_POLYGON_INCLUSION,
)
from .state import Item

__all__ = ["inside_fence"]

INCLUSIONS = (CMD_FENCE_POLYGON_INCLUSION, CMD_FENCE_CIRCLE_INCLUSION)
POLYGONS = (CMD_FENCE_POLYGON_INCLUSION, CMD_FENCE_POLYGON_EXCLUSION)


def _in_polygon(point: tuple[float, float], vertices: list[tuple[float, float]]) -> bool:
    """Whether ``point`` is inside ``vertices`` (north, east): the even-odd crossing rule."""
    n, e = point
    inside = False
    for (n1, e1), (n2, e2) in zip(vertices, vertices[1:] + vertices[:1], strict=True):
        if (e1 > e) != (e2 > e) and n < n1 + (e - e1) * (n2 - n1) / (e2 - e1):
            inside = not inside
    return inside


def inside_fence(fence: list[Item], lat: float, lon: float) -> bool:
    """Whether ``lat, lon`` (deg) is allowed by ``fence`` (True for an empty fence)."""
    projection = LocalProjection(lat, lon)

    def local(item: Item) -> tuple[float, float]:
        return projection.project(item.x * 1e-7, item.y * 1e-7)

    included: bool | None = None  # None: no inclusion to be inside of
    i = 0
    while i < len(fence):
        item = fence[i]
        if item.command in POLYGONS:
            count = max(int(item.param1), 1)
            inside = _in_polygon((0.0, 0.0), [local(v) for v in fence[i : i + count]])
            i += count
        else:
            inside = math.hypot(*local(item)) <= item.param1
            i += 1
        if item.command in INCLUSIONS:
            included = bool(included) or inside
        elif inside:
            return False
    return included is None or included
