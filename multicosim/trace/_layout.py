"""A Foxglove layout for a trace: map, 3D (the vehicle's pose among the obstacles), the
requirement's signals and margin, logs.

The file is Foxglove's layout format (``Layout`` menu, ``Import from file...``): panel
configurations by id and a tree of splits. Which panels appear depends on the channels the
trace holds; plots come from the requirement (its signals and margin) and from the scenario
(``TraceOptions.plots``, e.g. setpoints beside actual values).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

from ._convert import ROBUSTNESS_CHANNEL, TRAJECTORY_CHANNEL

__all__ = ["layout", "message_path"]

_PLAIN_TOPIC = re.compile(r"^[a-zA-Z0-9_/-]+$")
_PLAIN_FIELD = re.compile(r"^[a-zA-Z0-9_-]+$")
_COLORS = ("#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#d62728", "#8c564b")


def message_path(topic: str, *fields: str) -> str:
    """A Foxglove message path (``topic.field``), quoting names as Foxglove's parser needs."""

    def quote(name: str, plain: re.Pattern[str]) -> str:
        if plain.match(name):
            return name
        return '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'

    return ".".join([quote(topic, _PLAIN_TOPIC), *(quote(f, _PLAIN_FIELD) for f in fields)])


def _plot(title: str, paths: Sequence[tuple[str, str]]) -> dict[str, Any]:
    return {
        "foxglovePanelTitle": title,
        "paths": [
            {
                "value": value,
                "label": label,
                "enabled": True,
                "timestampMethod": "receiveTime",
                "color": _COLORS[i % len(_COLORS)],
            }
            for i, (value, label) in enumerate(paths)
        ],
        "showLegend": True,
        "legendDisplay": "top",
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "isSynced": True,
        "xAxisVal": "timestamp",
    }


def _split(ids: Sequence[Any], direction: str) -> Any:
    """Panels side by side (``row``) or stacked (``column``), in equal shares."""
    if len(ids) == 1:
        return ids[0]
    return {
        "first": ids[0],
        "second": _split(ids[1:], direction),
        "direction": direction,
        "splitPercentage": 100.0 / len(ids),
    }


def layout(
    channels: Mapping[str, str],
    plots: Sequence[tuple[str, Sequence[str]]] = (),
    metadata: Mapping[str, object] | None = None,
) -> dict[str, Any]:
    """The layout for a trace with ``channels`` (topic -> schema name)."""
    metadata = metadata or {}
    by_schema: dict[str, list[str]] = {}
    for topic, schema in channels.items():
        by_schema.setdefault(schema, []).append(topic)
    configs: dict[str, Any] = {}
    left: list[str] = []  # where: map and 3D
    right: list[str] = []  # why: the requirement's signals, its margin, the log
    scenario: list[str] = []  # the scenario's own plots (setpoints beside values, ...)

    fixes = by_schema.get("foxglove.LocationFix", [])
    shapes = by_schema.get("foxglove.GeoJSON", [])
    if fixes or shapes:
        follow = next((t for t in fixes if t.endswith("estimate")), fixes[0] if fixes else "")
        configs["map!mcs"] = {
            "layer": "map",
            "zoomLevel": 18,
            "followTopic": follow,
            "disabledTopics": [],
            "customTileUrl": "",
            "topicColors": {t: _COLORS[i % len(_COLORS)] for i, t in enumerate(fixes + shapes)},
        }
        left.append("map!mcs")
    poses = by_schema.get("foxglove.PoseInFrame", [])
    scenes = by_schema.get("foxglove.SceneUpdate", [])  # the world's obstacles
    if poses or scenes:
        topics: dict[str, Any] = {t: {"visible": True} for t in scenes}
        topics |= {t: {"visible": True, "type": "axis", "axisScale": 2} for t in poses}
        configs["3D!mcs"] = {
            "followTfFrame": "map",
            "followMode": "follow-pose",
            "topics": topics,
            "layers": {
                "grid": {"visible": True, "layerId": "foxglove.Grid", "size": 100, "divisions": 20}
            },
        }
        left.append("3D!mcs")

    signals = metadata.get("signals")
    if TRAJECTORY_CHANNEL in channels and isinstance(signals, list | tuple) and signals:
        paths = [(message_path(TRAJECTORY_CHANNEL, str(s)), str(s)) for s in signals]
        configs["Plot!signals"] = _plot(
            f"requirement signals: {metadata.get('requirement')}", paths
        )
        right.append("Plot!signals")
    if ROBUSTNESS_CHANNEL in channels:
        configs["Plot!margin"] = _plot(
            f"margin of {metadata.get('predicate') or 'the requirement'} (< 0: violated)",
            [(message_path(ROBUSTNESS_CHANNEL, "margin"), "margin")],
        )
        right.append("Plot!margin")
    for index, (title, values) in enumerate(plots):
        shown = [
            (v, v.rsplit("/", 1)[-1]) for v in values if v.split(".", 1)[0].strip('"') in channels
        ]
        if shown:
            configs[f"Plot!scenario{index}"] = _plot(title, shown)
            scenario.append(f"Plot!scenario{index}")
    logs = by_schema.get("foxglove.Log", [])
    if logs:
        configs["RosOut!mcs"] = {"searchTerms": [], "minLogLevel": 1, "topicToRender": logs[0]}
        right.append("RosOut!mcs")
    if not left and not right and not scenario:
        first = next(iter(sorted(channels)), "")
        configs["RawMessages!mcs"] = {"topicPath": message_path(first) if first else ""}
        right.append("RawMessages!mcs")

    columns = [c for c in (left, right, scenario) if c]
    tree = _split([_split(c, "column") for c in columns], "row")
    return {
        "configById": configs,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": tree,
    }
