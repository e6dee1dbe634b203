"""What an FMU puts on topics: its record (one typed message per step), values, log lines.

* Every step an FMU component publishes its **record** on its own topic (the component's
  name): a msgspec Struct generated from the model description, with the FMU's time and one
  field per recorded variable (its outputs, and the inputs and locals asked for), each
  described in its JSON schema with its causality, unit and range. A trace writes it as one
  channel per FMU; [`result`][multicosim.fmi.FMUNode.result] reads it back as FMPy does.
* A variable mapped to a topic (``outputs={"h": "height"}``) is published there as a plain
  value: a float, an int, a bool, a str, bytes, or a flat list (row-major) for an FMI 3 array.
  An input topic is read as the same: a value of the input's type, validated on receipt
  (range, array length).
* The FMU's own log messages go to ``NAME/log`` as [`LogLine`][multicosim.fmi.messages.LogLine]; a
  trace shows them as a ``foxglove.Log`` channel.
"""

from __future__ import annotations

import functools
import keyword
import math
import re
from collections.abc import Sequence
from typing import Annotated, Any

import msgspec
import numpy as np

from .model import Model, Variable

__all__ = [
    "FOXGLOVE_LEVELS",
    "LogLine",
    "columns",
    "record_type",
    "result_dtype",
    "value_type",
]

# FMI status -> Foxglove log level (DEBUG 1, INFO 2, WARNING 3, ERROR 4, FATAL 5)
FOXGLOVE_LEVELS = {"OK": 2, "Warning": 3, "Discard": 3, "Error": 4, "Fatal": 5, "Pending": 2}

# The order fmpy.simulate_fmu gives its result's columns: by type, then as declared.
_FMI2_ORDER = {"Real": 0, "Integer": 1, "Enumeration": 1, "Boolean": 2}
_FMI3_ORDER = {
    t: i
    for i, t in enumerate(
        (
            "Float32",
            "Float64",
            "Int8",
            "UInt8",
            "Int16",
            "UInt16",
            "Int32",
            "UInt32",
            "Int64",
            "UInt64",
            "Boolean",
        )
    )
}
_FMI3_ORDER["Enumeration"] = _FMI3_ORDER["Int64"]
_NUMPY = {
    "Real": np.float64,
    "Integer": np.int32,
    "Enumeration": np.int32,
    "Boolean": np.bool_,
    "Float32": np.float32,
    "Float64": np.float64,
    "Int8": np.int8,
    "UInt8": np.uint8,
    "Int16": np.int16,
    "UInt16": np.uint16,
    "Int32": np.int32,
    "UInt32": np.uint32,
    "Int64": np.int64,
    "UInt64": np.uint64,
}


_INT64_MAX = 2**63 - 1


class LogLine(msgspec.Struct, frozen=True, gc=False):
    """One of the FMU's log messages: its FMI status, the category, the text."""

    status: str
    category: str
    message: str


def columns(model: Model, variables: Sequence[Variable]) -> list[Variable]:
    """``variables`` in fmpy.simulate_fmu's column order (strings and binaries last)."""
    order = _FMI3_ORDER if model.fmi_version.startswith("3") else _FMI2_ORDER
    ranked = sorted(enumerate(variables), key=lambda iv: (order.get(iv[1].type, len(order)), iv[0]))
    return [v for _, v in ranked]


def result_dtype(
    model: Model, variables: Sequence[Variable], shapes: dict[str, tuple[int, ...]]
) -> np.dtype[Any]:
    """The dtype of fmpy.simulate_fmu's result for ``variables`` (in ``columns`` order).

    Like FMPy's, it holds the numbers and booleans; strings and binaries stay in the record.
    """
    fields: list[Any] = [("time", np.float64)]
    for v in variables:
        kind = "Int64" if model.fmi_version.startswith("3") and v.type == "Enumeration" else v.type
        tp = _NUMPY.get(kind)
        if tp is None:
            continue
        shape = shapes.get(v.name, ())
        fields.append((v.name, tp, shape) if shape else (v.name, tp))
    return np.dtype(fields)


def value_type(v: Variable, shape: tuple[int, ...]) -> Any:
    """The type a topic carries for ``v``: checked on receipt (range, array length)."""
    tp: Any = v.python_type
    low, high = v.bounds()
    if tp in (int, float) and (low is not None or high is not None):
        cast = int if tp is int else float
        ge = None if low is None else cast(low)
        le = None if high is None else cast(high)
        if tp is int and le is not None and le > _INT64_MAX:
            le = None  # msgspec checks only bounds within int64; UInt64 holds more

        tp = Annotated[tp, msgspec.Meta(ge=ge, le=le)]
    if v.is_array:
        size = math.prod(shape)
        return Annotated[list[tp], msgspec.Meta(min_length=size, max_length=size)]
    return tp


def record_type(
    model: Model, variables: Sequence[Variable], shapes: tuple[tuple[int, ...], ...]
) -> Any:
    """The Struct an FMU of ``model`` publishes each step: ``time`` and ``variables``."""
    return _record_type(model, tuple(variables), shapes)


@functools.cache
def _record_type(
    model: Model, variables: tuple[Variable, ...], shapes: tuple[tuple[int, ...], ...]
) -> Any:
    fields: list[tuple[str, Any]] = [
        (
            "time",
            Annotated[
                float, msgspec.Meta(description="The FMU's time", extra_json_schema={"unit": "s"})
            ],
        )
    ]
    rename: dict[str, str] = {}
    taken = {"time"}
    for v, shape in zip(variables, shapes, strict=True):
        attribute = _identifier(v.name, taken)
        taken.add(attribute)
        if attribute != v.name:
            rename[attribute] = v.name
        fields.append((attribute, Annotated[_field_type(v, shape), _meta(v, shape)]))
    title = re.sub(r"\W", "_", model.name)
    return msgspec.defstruct(
        title,
        fields,
        module="multicosim.fmi.records",
        frozen=True,
        gc=False,
        rename=rename or None,
    )


def _field_type(v: Variable, shape: tuple[int, ...]) -> Any:
    tp: Any = v.python_type
    return list[tp] if v.is_array else tp


def _meta(v: Variable, shape: tuple[int, ...]) -> msgspec.Meta:
    extra: dict[str, Any] = {"causality": v.causality, "fmiType": v.type}
    if v.unit:
        extra["unit"] = v.unit
    if v.is_array:
        extra["shape"] = list(shape)  # the values are a flat list, row-major
    else:
        bounds = {"minimum": v.min, "maximum": v.max}
        extra.update({k: b for k, b in bounds.items() if b is not None})
    return msgspec.Meta(description=v.description or v.name, extra_json_schema=extra)


def _identifier(name: str, taken: set[str]) -> str:
    # Struct attributes must be identifiers; the wire and the trace keep the FMU's names.
    base = re.sub(r"\W", "_", name)
    if not base or base[0].isdigit() or keyword.iskeyword(base):
        base = "v_" + base
    candidate, n = base, 1
    while candidate in taken:
        n += 1
        candidate = f"{base}_{n}"
    return candidate
