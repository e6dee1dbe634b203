"""The model description as the contract: an FMU's variables, their types, ranges and units.

[`describe`][multicosim.fmi.model.describe] reads an FMU's ``modelDescription.xml`` with FMPy
(validated against the FMI schema) and checks what multicosim can run: FMI 2.0 or 3.0, a
co-simulation or model-exchange interface, a binary for this platform (or C sources, compiled with
FMPy on request). Every configuration of an [`FMU`][multicosim.fmi.FMU] is checked against it before
anything starts; an unknown or misused variable is a ConfigurationError that lists the
variables the FMU has of the causality asked for.
"""

from __future__ import annotations

import builtins
import dataclasses
import functools
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

from ..core.deps import require
from ..core.errors import ConfigurationError

__all__ = [
    "INTERFACES",
    "Interface",
    "Model",
    "Variable",
    "describe",
]

Interface = Literal["CoSimulation", "ModelExchange"]
INTERFACES: tuple[Interface, ...] = ("CoSimulation", "ModelExchange")

# FMI type -> (Python type, lowest, highest); integers carry the range of their C type.
_INTEGER_RANGES = {
    "Integer": (-(2**31), 2**31 - 1),
    "Enumeration": (-(2**63), 2**63 - 1),
    "Int8": (-(2**7), 2**7 - 1),
    "UInt8": (0, 2**8 - 1),
    "Int16": (-(2**15), 2**15 - 1),
    "UInt16": (0, 2**16 - 1),
    "Int32": (-(2**31), 2**31 - 1),
    "UInt32": (0, 2**32 - 1),
    "Int64": (-(2**63), 2**63 - 1),
    "UInt64": (0, 2**64 - 1),
}
_PYTHON_TYPES: dict[str, type[Any]] = {
    "Real": float,
    "Float32": float,
    "Float64": float,
    "Boolean": bool,
    "String": str,
    "Binary": bytes,
    **dict.fromkeys(_INTEGER_RANGES, int),
}
# What FMI 3 adds that multicosim does not drive (see docs/guides/fmi.md).
_UNSUPPORTED_TYPES = {"Clock": "FMI 3 clocks are not supported"}


@dataclasses.dataclass(frozen=True, eq=False)
class Variable:
    """One variable of an FMU, as its model description declares it.

    ``type`` is the FMI type (``Real``, ``Integer``, ``Boolean``, ``String``,
    ``Enumeration`` in FMI 2; ``Float64``, ``Int8`` ... ``UInt64``, ``Binary`` in FMI 3);
    ``shape`` is ``()`` for a scalar and the array's dimensions otherwise (FMI 3), with
    structural parameters at their start values; ``unit`` is the variable's or its declared
    type's; ``min``/``max`` bound the values it accepts (its own or its type's).
    """

    name: str
    type: str
    causality: str
    variability: str
    initial: str | None
    value_reference: int
    shape: tuple[int, ...]
    start: Any
    unit: str | None
    min: float | None
    max: float | None
    description: str | None
    # Dimensions as (fixed size, or None) and (value reference of the structural parameter
    # that sets it, or None), for FMUs whose structural parameters resize the arrays.
    dimensions: tuple[tuple[int | None, int | None], ...] = ()

    @property
    def python_type(self) -> builtins.type[Any]:
        """The Python type of one element: float, int, bool, str or bytes."""
        return _PYTHON_TYPES[self.type]

    @property
    def is_array(self) -> bool:
        """Whether it is an FMI 3 array."""
        return bool(self.dimensions)

    def describe(self, shape: tuple[int, ...] | None = None) -> str:
        """``name`` with its type, shape and unit, as error messages show it."""
        text = f"{self.name} ({self.type}"
        shape = self.shape if shape is None else shape
        if shape:
            text += "[" + ",".join(map(str, shape)) + "]"
        if self.unit:
            text += f", {self.unit}"
        return text + ")"

    def allowed(self, shape: tuple[int, ...] | None = None) -> str:
        """What a value of this variable must be, in words (for error messages)."""
        shape = self.shape if shape is None else shape
        what = {float: "a number", int: "an integer", bool: "a bool", str: "a string"}.get(
            self.python_type, "bytes (or a hex string)"
        )
        low, high = self.bounds()
        if low is not None or high is not None:
            what += f" in [{_fmt(low)}, {_fmt(high)}]"
        if self.is_array:
            what = f"{math.prod(shape)} values (shape {shape}), each {what}"
        return f"{what}, as {self.describe(shape)} declares"

    def bounds(self) -> tuple[float | None, float | None]:
        """The lowest and highest value it takes: its min/max, within its integer type."""
        low, high = self.min, self.max
        limits = _INTEGER_RANGES.get(self.type)
        if limits is not None:
            low = limits[0] if low is None else max(low, limits[0])
            high = limits[1] if high is None else min(high, limits[1])
        return low, high

    def check(self, value: object, field: str, shape: tuple[int, ...] | None = None) -> Any:
        """``value`` as this variable takes it (a flat list for an array); ConfigurationError
        naming ``field`` for a wrong type, size, or a value outside its range."""
        shape = self.shape if shape is None else shape
        if not self.is_array:
            return self._element(value, field, value, shape)
        flat = _flatten(value)
        if flat is None or len(flat) != math.prod(shape):
            raise ConfigurationError(field, value, self.allowed(shape))
        return [self._element(x, field, value, shape) for x in flat]

    def _element(self, x: object, field: str, whole: object, shape: tuple[int, ...]) -> Any:
        item = getattr(x, "item", None)
        if callable(item) and not isinstance(x, bytes | str):  # a NumPy scalar
            x = item()
        value = _ACCEPT[self.python_type](x)
        if value is None:
            raise ConfigurationError(field, whole, self.allowed(shape))
        low, high = self.bounds()
        numeric = isinstance(value, int | float) and not isinstance(value, bool)
        if numeric and ((low is not None and value < low) or (high is not None and value > high)):
            raise ConfigurationError(field, whole, self.allowed(shape))
        return value


def _as_float(x: object) -> float | None:
    return float(x) if isinstance(x, int | float) and not isinstance(x, bool) else None


def _as_int(x: object) -> int | None:
    return x if isinstance(x, int) and not isinstance(x, bool) else None


def _as_bytes(x: object) -> bytes | None:
    if isinstance(x, str):  # as the model description writes a binary: hexadecimal
        try:
            return bytes.fromhex(x)
        except ValueError:
            return None
    return x if isinstance(x, bytes) else None


# Python type of an element -> the value it accepts as one (None: not one).
_ACCEPT: dict[Any, Any] = {
    float: _as_float,
    int: _as_int,
    bool: lambda x: x if isinstance(x, bool) else None,
    str: lambda x: x if isinstance(x, str) else None,
    bytes: _as_bytes,
}


@dataclasses.dataclass(frozen=True, eq=False)
class Model:
    """An FMU's model description, read and validated with FMPy.

    ``platforms`` are those FMPy finds binaries for (``c-code`` when it carries C sources);
    ``default_step`` is the step the FMU states (FMI 3's ``fixedInternalStepSize``, else the
    default experiment's ``stepSize``), the period of an [`FMU`][multicosim.fmi.FMU] that
    names none. ``description`` is FMPy's ``ModelDescription`` itself.
    """

    path: Path
    fmi_version: str
    name: str
    interfaces: tuple[Interface, ...]
    platforms: tuple[str, ...]
    variables: Mapping[str, Variable]
    default_step: float | None
    start_time: float | None
    stop_time: float | None
    tolerance: float | None
    fixed_step: float | None
    description: Any = dataclasses.field(repr=False)

    @property
    def label(self) -> str:
        """How errors name the FMU: its file name and model name."""
        return f"{self.path.name} (model {self.name!r}, FMI {self.fmi_version})"

    @property
    def runnable_here(self) -> bool:
        """Whether it has a binary for this platform."""
        from fmpy import platform

        return platform in self.platforms

    @property
    def has_sources(self) -> bool:
        """Whether it carries C sources (FMPy can compile a binary from them)."""
        return "c-code" in self.platforms

    def of(self, *causalities: str) -> list[Variable]:
        """The variables of these causalities, in model-description order."""
        return [v for v in self.variables.values() if v.causality in causalities]

    def names(self, *causalities: str) -> str:
        """The names of the variables of these causalities, for an error message."""
        found = [v.describe() for v in self.of(*causalities)]
        return ", ".join(found) if found else "none"

    def variable(self, name: object, field: str, *causalities: str) -> Variable:
        """The variable ``name`` of one of ``causalities``; ConfigurationError naming ``field``
        and listing the FMU's variables of those causalities otherwise."""
        wanted = " or ".join(causalities)
        listed = f"{self.label} has these variables of causality {wanted}: " + self.names(
            *causalities
        )
        found = self.variables.get(name) if isinstance(name, str) else None
        if found is None:
            raise ConfigurationError(field, name, f"a variable name; {listed}")
        if found.type in _UNSUPPORTED_TYPES:
            raise ConfigurationError(field, name, f"{_UNSUPPORTED_TYPES[found.type]}; {listed}")
        if found.causality not in causalities:
            raise ConfigurationError(
                field,
                name,
                f"a variable of causality {wanted}, not {found.causality} "
                f"({found.describe()}); {listed}",
            )
        return found

    def range(self, name: str) -> tuple[float, float]:
        """The ``(min, max)`` the model description declares for ``name`` (a search space).

        ConfigurationError if the variable is unknown or declares no finite range.
        """
        variable = self.variables.get(name)
        if variable is None:
            raise ConfigurationError("name", name, f"a variable of {self.label}")
        if variable.min is None or variable.max is None:
            raise ConfigurationError(
                "name",
                name,
                f"a variable with min and max in {self.label} "
                f"({variable.describe()} declares min={variable.min}, max={variable.max})",
            )
        return (variable.min, variable.max)


def describe(path: str | os.PathLike[str]) -> Model:
    """Read and check the FMU at ``path`` (a ``.fmu`` file or an extracted FMU's directory).

    ConfigurationError (field ``path``) for a missing file, a file that is not an FMU, a
    model description that does not validate, FMI 1.0, or an FMU without a co-simulation or
    model-exchange interface. Whether it has a binary for this platform is checked where it
    is run ([`Model.runnable_here`][multicosim.fmi.model.Model.runnable_here]).
    """
    resolved = Path(path).expanduser().resolve()
    if not resolved.exists():
        raise ConfigurationError(
            "path", str(path), "an existing .fmu file (or an extracted FMU's directory)"
        )
    if resolved.is_dir():
        if not (resolved / "modelDescription.xml").is_file():
            raise ConfigurationError(
                "path", str(path), "an FMU: this directory holds no modelDescription.xml"
            )
        # Keyed on every file's modification time: binaries built or removed change it.
        signature: tuple[tuple[object, ...], ...] = tuple(
            (str(p.relative_to(resolved)), p.stat().st_mtime_ns)
            for p in sorted(resolved.rglob("*"))
            if p.is_file()
        )
    else:
        stat = resolved.stat()
        signature = ((resolved.name, stat.st_mtime_ns, stat.st_size),)
    return _describe(resolved, signature)


@functools.lru_cache(maxsize=64)
def _describe(path: Path, signature: tuple[tuple[object, ...], ...]) -> Model:
    # Keyed on what the files are too: a rebuilt FMU at the same path is read again.
    fmpy = require("fmpy", "fmi")
    from fmpy.model_description import ValidationError, read_model_description

    try:
        if path.is_dir():
            md = read_model_description(str(path), validate=True)
        else:
            # Opened here so that it is closed here: FMPy leaves its own handle to the
            # garbage collector when the description does not validate.
            with open(path, "rb") as stream:
                md = read_model_description(stream, validate=True)
    except ValidationError as exc:
        problems = "; ".join(str(p).strip() for p in getattr(exc, "problems", [exc])[:5])
        raise ConfigurationError(
            "path", str(path), f"an FMU whose model description is valid ({problems})"
        ) from exc
    except Exception as exc:  # a corrupt zip, malformed XML, ...: FMPy raises what it meets
        raise ConfigurationError(
            "path", str(path), f"an FMU (a zip with a modelDescription.xml): {exc}"
        ) from exc
    if md.fmiVersion not in ("2.0",) and not str(md.fmiVersion).startswith("3."):
        raise ConfigurationError(
            "path", str(path), f"an FMI 2.0 or 3.0 FMU (this one is FMI {md.fmiVersion})"
        )
    interfaces: tuple[Interface, ...] = ()
    if md.coSimulation is not None:
        interfaces += ("CoSimulation",)
    if md.modelExchange is not None:
        interfaces += ("ModelExchange",)
    if not interfaces:
        raise ConfigurationError(
            "path",
            str(path),
            "an FMU with a co-simulation or model-exchange interface (FMI 3 scheduled "
            "execution is not supported)",
        )
    experiment = md.defaultExperiment
    fixed = md.coSimulation.fixedInternalStepSize if md.coSimulation is not None else None
    step = _float(experiment.stepSize) if experiment is not None else None
    return Model(
        path=path,
        fmi_version=str(md.fmiVersion),
        name=str(md.modelName),
        interfaces=interfaces,
        platforms=tuple(fmpy.supported_platforms(str(path))),
        variables=_variables(md),
        default_step=_float(fixed) if fixed is not None else step,
        start_time=_float(experiment.startTime) if experiment is not None else None,
        stop_time=_float(experiment.stopTime) if experiment is not None else None,
        tolerance=_float(experiment.tolerance) if experiment is not None else None,
        fixed_step=_float(fixed) if fixed is not None else None,
        description=md,
    )


def _float(value: object) -> float | None:
    return None if value is None else float(str(value))


def _variables(md: Any) -> dict[str, Variable]:
    out: dict[str, Variable] = {}
    for v in md.modelVariables:
        declared = v.declaredType
        kind = str(v.type)
        unit = v.unit or (declared.unit if declared is not None else None)
        low = _bound(v.min if v.min is not None else getattr(declared, "min", None))
        high = _bound(v.max if v.max is not None else getattr(declared, "max", None))
        dims = tuple(
            (int(d.start) if d.start is not None else None, d.valueReference) for d in v.dimensions
        )
        out[str(v.name)] = Variable(
            name=str(v.name),
            type=kind,
            causality=str(v.causality),
            variability=str(v.variability),
            initial=v.initial,
            value_reference=int(v.valueReference),
            shape=tuple(int(n) for n in (v.shape or ())),
            start=_parse_start(kind, v.start, bool(v.dimensions)),
            unit=unit,
            min=low,
            max=high,
            description=v.description,
            dimensions=dims,
        )
    return out


def _bound(text: object) -> float | None:
    if text is None:
        return None
    value = float(str(text))
    return value if math.isfinite(value) else None


def _parse_start(kind: str, text: str | None, array: bool) -> Any:
    """A start attribute as Python values (a list of them for an array)."""
    if text is None:
        return None
    items: Sequence[str] = str(text).split() if array else [str(text)]
    if not array:
        items = [str(text)]  # a scalar string keeps its spaces
    parse = _PARSE.get(_PYTHON_TYPES.get(kind), str)
    parsed = [parse(item) for item in items]
    return parsed if array else parsed[0]


# Python type of an element -> how a start attribute's text becomes one.
_PARSE: dict[Any, Any] = {
    bool: lambda text: text.lower() in ("true", "1"),
    int: int,
    float: float,
    bytes: bytes.fromhex,
}


def _flatten(value: object) -> list[Any] | None:
    """A (nested) sequence or NumPy array as a flat list, row-major; None for a scalar."""
    tolist = getattr(value, "tolist", None)
    if callable(tolist):
        value = tolist()
    if isinstance(value, str | bytes) or not isinstance(value, Sequence):
        return None
    flat: list[Any] = []
    for item in value:
        inner = _flatten(item)
        if inner is None:
            flat.append(item)
        else:
            flat.extend(inner)
    return flat


def _fmt(bound: float | None) -> str:
    if bound is None:
        return "-inf"
    return f"{bound:g}" if not float(bound).is_integer() or abs(bound) < 1e15 else str(int(bound))
