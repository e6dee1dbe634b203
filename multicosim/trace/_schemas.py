"""Channel schemas: JSON Schema (draft 2020-12) from message types, and Foxglove's own.

Every schema a trace carries declares its dialect (``$schema``). Generated schemas describe
each message as an object (array-like Structs too: Foxglove's ``json`` encoding wants objects
with named fields); Foxglove's well-known schemas are loaded unmodified from the files that
Foxglove publishes (``foxglove/``, see its README).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import typing
from collections.abc import Mapping, Sequence
from importlib import resources
from typing import Any

import msgspec

__all__ = [
    "DIALECT",
    "GEOJSON",
    "LOCATION_FIX",
    "LOG",
    "POSE_IN_FRAME",
    "SCENE_UPDATE",
    "Schema",
    "foxglove_schema",
    "object_schema",
    "schema_for",
    "stamp",
]

DIALECT = "https://json-schema.org/draft/2020-12/schema"


@dataclasses.dataclass(frozen=True)
class Schema:
    """A channel's JSON schema and its name (Foxglove recognises well-known names)."""

    name: str
    schema: Mapping[str, Any]


def object_schema(title: str, properties: Mapping[str, Any], **extra: Any) -> Schema:
    """A schema named ``title`` for objects with ``properties``, declaring the dialect."""
    return Schema(
        title,
        {"$schema": DIALECT, "title": title, "type": "object", "properties": dict(properties)}
        | extra,
    )


@functools.cache
def foxglove_schema(name: str) -> Schema:
    """Foxglove's published schema ``foxglove.NAME`` (for example ``"LocationFix"``)."""
    text = resources.files(__package__).joinpath("foxglove", f"{name}.json").read_text()
    schema = json.loads(text)
    return Schema(str(schema["title"]), {"$schema": DIALECT, **schema})


LOCATION_FIX = foxglove_schema("LocationFix")
POSE_IN_FRAME = foxglove_schema("PoseInFrame")
LOG = foxglove_schema("Log")
GEOJSON = foxglove_schema("GeoJSON")
SCENE_UPDATE = foxglove_schema("SceneUpdate")


@functools.cache
def schema_for(tp: Any) -> Schema:
    """The JSON schema of message type ``tp``, rooted at the type itself (not a ``$ref``).

    An array-like Struct is described as the object of its fields (what a trace writes).
    A float may be null: JSON has no NaN or infinity (an unset value, a clearance with no
    obstacle around), and msgspec writes them as null.
    """
    generated = _nullable_numbers(msgspec.json.schema(_as_object_type(tp)))
    defs = dict(generated.get("$defs", {}))
    ref = generated.get("$ref", "")
    name = ref.rsplit("/", 1)[-1] if ref else getattr(tp, "__name__", str(tp))
    root = dict(defs.pop(name, generated))
    root.pop("$ref", None)
    if defs:
        root["$defs"] = defs  # nested types keep resolving as "#/$defs/..."
    return Schema(_qualified(tp), {"$schema": DIALECT, **root})


def _nullable_numbers(node: Any) -> Any:
    if isinstance(node, dict):
        if node.get("type") == "number":
            node = {**node, "type": ["number", "null"]}
        return {k: _nullable_numbers(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_nullable_numbers(v) for v in node]
    return node


def is_array_like(tp: Any) -> bool:
    """Whether ``tp`` is a msgspec Struct encoded as an array (its JSON is a list)."""
    config = getattr(tp, "__struct_config__", None)
    return bool(config is not None and config.array_like)


@functools.cache
def _as_object_type(tp: Any) -> Any:
    """``tp`` itself, or for an array-like Struct a twin with the same fields as an object."""
    if not is_array_like(tp):
        return tp
    hints = typing.get_type_hints(tp)
    fields = [(name, hints[name]) for name in tp.__struct_fields__]
    twin = msgspec.defstruct(tp.__name__, fields, module=tp.__module__)
    twin.__doc__ = tp.__doc__
    return twin


def _qualified(tp: Any) -> str:
    module = getattr(tp, "__module__", "")
    qualname = getattr(tp, "__qualname__", None) or getattr(tp, "__name__", str(tp))
    return f"{module}.{qualname}" if module else str(qualname)


def stamp(time_ns: int) -> dict[str, int]:
    """A Foxglove ``time`` (``{"sec", "nsec"}``) for ``time_ns`` nanoseconds."""
    return {"sec": time_ns // 1_000_000_000, "nsec": time_ns % 1_000_000_000}


def signals_schema(names: Sequence[str]) -> Schema:
    """Samples of a trajectory: ``time`` and one number (null where not finite) per signal."""
    props = {"time": {"type": "number"}, **{n: {"type": ["number", "null"]} for n in names}}
    return object_schema("multicosim.Sample", props)


_NUMBER = {"type": "number"}
PATH_POINT = object_schema(
    "multicosim.PathPoint",
    {
        "east": {**_NUMBER, "description": "metres east of the local origin"},
        "north": {**_NUMBER, "description": "metres north of the local origin"},
        "up": {**_NUMBER, "description": "metres above the local origin"},
    },
    description="A point of a path in the scenario's local east-north-up frame",
    required=["east", "north", "up"],
)
PLAN = object_schema(
    "multicosim.Plan",
    {
        "points": {
            "type": "array",
            "items": {k: v for k, v in PATH_POINT.schema.items() if k != "$schema"},
        }
    },
    description="The planned path, in the local east-north-up frame",
)
OBSTACLES = object_schema(
    "multicosim.Obstacles",
    {
        "obstacles": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "name": {"type": "string"},
                    "height": {**_NUMBER, "description": "metres above the ground"},
                    "footprint": {
                        "type": "array",
                        "items": {k: v for k, v in PATH_POINT.schema.items() if k != "$schema"},
                        "description": "the outline on the ground (up 0)",
                    },
                },
            },
        }
    },
    description="The world's obstacles: footprints in the local east-north-up frame, heights",
)
ROBUSTNESS = object_schema(
    "multicosim.Robustness",
    {
        "formula": {"type": "string"},
        "robustness": {"type": ["number", "null"]},
        "margin": {"type": ["number", "null"]},
        "predicate": {"type": "string"},
    },
    description="A requirement's robustness and its deciding predicate's margin over time",
)
ANY_OBJECT = Schema("multicosim.Any", {"$schema": DIALECT, "type": "object"})
WRAPPED = object_schema(
    "multicosim.Value", {"value": {}}, description="A message that is not an object"
)
