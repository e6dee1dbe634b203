"""What a trace of the PX4 scenario shows: the world's truth on the map and in 3-D."""

from __future__ import annotations

from typing import Any

from ..trace import TraceOptions, location_fix, pose_in_frame
from ._config import MuJoCo, world_topics
from ._hil import Truth

__all__ = ["trace_options"]

# Truth is array-like: its JSON form is a list in field order.
_FIELD = {name: i for i, name in enumerate(Truth.__struct_fields__)}


def _fields(message: Any) -> Any:
    # Foxglove's JSON encoding wants objects, so the trace wraps the list as {"value": [...]}.
    return message["value"] if isinstance(message, dict) else message


def trace_options(world: MuJoCo) -> TraceOptions:
    """Truth typed, as ``foxglove.LocationFix`` (WGS84) and ``foxglove.PoseInFrame`` (ENU).

    Truth carries no attitude, so the pose's orientation is the identity.
    """
    f = _FIELD
    home_alt = world.home.alt

    def fix(m: Any) -> tuple[float, float, float]:
        m = _fields(m)
        return m[f["lat"]], m[f["lon"]], home_alt + m[f["alt"]]

    def pose(m: Any) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        m = _fields(m)
        return (m[f["east"]], m[f["north"]], -m[f["down"]]), (1.0, 0.0, 0.0, 0.0)

    truth = world_topics(world).truth
    return TraceOptions(
        types={truth: Truth},
        converters=[location_fix(truth, fix), pose_in_frame(truth, pose)],
    )
