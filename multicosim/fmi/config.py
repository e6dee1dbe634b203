"""An FMU component's configuration, and the plan it makes against the model description.

[`FMUConfig`][multicosim.fmi.config.FMUConfig] is what the FMU participant program runs (it travels
as JSON to a process or a container); ``plan`` checks it against the model description, the
contract, and resolves it: which variables are recorded and in what order, what each topic carries,
which values are set. Host and participant make the same plan from the same configuration.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, Literal

import msgspec

from ..core.clock import to_ns
from ..core.errors import ConfigurationError
from .instance import settable
from .messages import columns, record_type, result_dtype, value_type
from .model import Interface, Model, Variable, describe

__all__ = [
    "PARAMETERS",
    "SETTABLE",
    "SOLVERS",
    "FMUConfig",
    "Plan",
    "Solver",
    "check_values",
    "plan",
    "shapes_of",
]

Solver = Literal["CVode", "Euler"]
# The solvers FMPy ships for model exchange: SUNDIALS CVode (BDF) and forward Euler.
SOLVERS: tuple[Solver, ...] = ("CVode", "Euler")
# The causalities of the variables an FMU's configuration may set.
PARAMETERS = ("parameter", "structuralParameter")
SETTABLE = (*PARAMETERS, "input", "output", "local")


class FMUConfig(msgspec.Struct, frozen=True, kw_only=True):
    """What an FMU participant runs (see [`multicosim.fmi.FMU`][multicosim.fmi.FMU] for the fields).

    ``values`` holds parameters and start values by name; ``inputs`` and ``outputs`` map
    variables to topics; ``record`` names the variables recorded beside the outputs;
    ``workdir`` is where the FMU is extracted (None: a temporary directory); ``log_file``
    receives the FMU's log messages (None: the program's log).
    """

    path: str
    name: str
    period: float
    interface: Interface
    values: dict[str, Any] = {}
    inputs: dict[str, str] = {}
    outputs: dict[str, str] = {}
    record: tuple[str, ...] = ()
    solver: Solver = "CVode"
    tolerance: float | None = None
    start_time: float = 0.0
    stop_time: float | None = None
    debug_logging: bool = False
    workdir: str | None = None
    log_file: str | None = None


@dataclasses.dataclass(frozen=True)
class Plan:
    """A configuration resolved against its model (see ``plan``)."""

    config: FMUConfig
    model: Model
    recorded: tuple[Variable, ...]  # in fmpy.simulate_fmu's column order
    shapes: dict[str, tuple[int, ...]]
    record_type: Any
    inputs: tuple[tuple[str, Variable, Any], ...]  # (topic, variable, value type)
    outputs: tuple[tuple[int, str], ...]  # (index into ``recorded``, topic)
    values: dict[str, Any]  # checked, arrays as flat lists

    @property
    def topic(self) -> str:
        """Where the record goes: the component's name."""
        return self.config.name

    @property
    def log_topic(self) -> str:
        """Where the FMU's log messages go."""
        return f"{self.config.name}/log"

    def dtype(self) -> Any:
        """The dtype of the result (fmpy.simulate_fmu's for the recorded variables)."""
        return result_dtype(self.model, self.recorded, self.shapes)


def plan(config: FMUConfig, model: Model | None = None) -> Plan:
    """Check ``config`` against its FMU's model description and resolve it.

    Raises ConfigurationError naming the field, the value and what the FMU allows.
    """
    model = model or describe(config.path)
    if config.interface not in model.interfaces:
        raise ConfigurationError(
            "interface", config.interface, f"one of {model.interfaces} ({model.label} has no other)"
        )
    if config.solver not in SOLVERS:
        raise ConfigurationError("solver", config.solver, f"one of {SOLVERS} (FMPy's solvers)")
    _check_times(config, model)
    shapes = shapes_of(model, config.values, "values")
    values = check_values(model, config.values, "values", *SETTABLE, shapes=shapes)
    extra = []
    for i, name in enumerate(config.record):
        extra.append(model.variable(name, f"record[{i}]", "input", "output", "local", "parameter"))
    outputs = model.of("output")
    recorded = tuple(columns(model, list(dict.fromkeys([*outputs, *extra]))))
    index = {v.name: i for i, v in enumerate(recorded)}
    taken = {config.name, f"{config.name}/log"}
    published: list[tuple[int, str]] = []
    seen_topics: dict[str, str] = {}
    for name, topic in config.outputs.items():
        field = f"outputs[{name!r}]"
        local = model.variables.get(name)
        if local is not None and local.causality == "local" and name not in config.record:
            raise ConfigurationError(
                "outputs",
                name,
                f"an output, or a local variable named in record=(...) too (publishing a "
                f"local is asked for by recording it); {local.describe()} is a local",
            )
        recorded_locals = ("local",) if name in config.record else ()
        v = model.variable(name, "outputs", "output", *recorded_locals)
        _check_topic(field, topic, taken)
        if topic in seen_topics:
            raise ConfigurationError(
                field, topic, f"a topic of its own ({seen_topics[topic]!r} is published there)"
            )
        seen_topics[topic] = name
        published.append((index[name], topic))
    subscribed: list[tuple[str, Variable, Any]] = []
    by_topic: dict[str, Any] = {}
    for name, topic in config.inputs.items():
        field = f"inputs[{name!r}]"
        v = model.variable(name, "inputs", "input")
        _check_topic(field, topic, taken | set(seen_topics))
        tp = value_type(v, shapes.get(name, ()))
        if topic in by_topic and by_topic[topic] != tp:
            raise ConfigurationError(
                field, topic, "a topic whose other inputs take the same type of value"
            )
        by_topic[topic] = tp
        subscribed.append((topic, v, tp))
    shape_of = tuple(shapes.get(v.name, ()) for v in recorded)
    return Plan(
        config=config,
        model=model,
        recorded=recorded,
        shapes={v.name: shapes[v.name] for v in recorded if v.name in shapes},
        record_type=record_type(model, recorded, shape_of),
        inputs=tuple(subscribed),
        outputs=tuple(published),
        values=values,
    )


def check_values(
    model: Model,
    given: object,
    field_name: str,
    *causalities: str,
    shapes: Mapping[str, tuple[int, ...]] | None = None,
) -> dict[str, Any]:
    """``given`` (variable name -> value) checked against ``model``: each a settable variable
    of one of ``causalities``, each value of its type, size and range (arrays flattened, at
    the ``shapes`` the structural parameters give them, ``shapes_of``)."""
    if not isinstance(given, Mapping):
        raise ConfigurationError(field_name, given, "a mapping of variable name to value")
    out: dict[str, Any] = {}
    for name, value in given.items():
        field = f"{field_name}[{name!r}]"
        v = model.variable(name, field, *causalities)
        if not settable(v):
            raise ConfigurationError(
                field,
                value,
                f"nothing: {v.describe()} is {v.variability} with initial={v.initial}, "
                "so its value cannot be set",
            )
        out[name] = v.check(value, field, (shapes or {}).get(name))
    return out


def shapes_of(model: Model, given: object, field_name: str) -> dict[str, tuple[int, ...]]:
    """The shape of every array of ``model`` once the structural parameters in ``given``
    (variable name -> value; the others keep their start values) are set."""
    structural: dict[int, int] = {}
    for v in model.of("structuralParameter"):
        value = given.get(v.name, v.start) if isinstance(given, Mapping) else v.start
        checked = v.check(value if value is not None else 0, f"{field_name}[{v.name!r}]")
        structural[v.value_reference] = int(checked)
    return {v.name: _shape(v, structural) for v in model.variables.values() if v.is_array}


def _shape(v: Variable, structural: Mapping[int, int]) -> tuple[int, ...]:
    return tuple(
        size if size is not None else structural.get(vr if vr is not None else -1, 0)
        for size, vr in v.dimensions
    )


def _check_topic(field: str, topic: object, taken: set[str]) -> None:
    if not isinstance(topic, str) or not topic or topic != topic.strip():
        raise ConfigurationError(field, topic, "a non-empty topic name")
    if topic in taken:
        raise ConfigurationError(
            field, topic, f"a topic other than {sorted(taken)} (the FMU's own, or taken)"
        )


def _check_times(config: FMUConfig, model: Model) -> None:
    period = config.period
    if (
        isinstance(period, bool)
        or not isinstance(period, int | float)
        or not math.isfinite(period)
        or period <= 0
    ):
        raise ConfigurationError("period", period, "a positive number of seconds")
    if abs(to_ns(period) / 1e9 - period) > 1e-12 * max(1.0, period):
        raise ConfigurationError(
            "period", period, "a whole number of nanoseconds (the simulated clock's resolution)"
        )
    fixed = model.fixed_step
    if config.interface == "CoSimulation" and fixed is not None:
        steps = period / fixed
        if round(steps) < 1 or not math.isclose(steps, round(steps), rel_tol=1e-9):
            raise ConfigurationError(
                "period",
                period,
                f"a multiple of {fixed:g} s, the fixed internal step of {model.label} "
                "(it cannot end a communication step between two of its own)",
            )
    for field in ("start_time", "tolerance"):
        value = getattr(config, field)
        if value is not None and (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ConfigurationError(field, value, "a finite number")
    if config.tolerance is not None and config.tolerance <= 0:
        raise ConfigurationError("tolerance", config.tolerance, "None or a positive tolerance")
    stop = config.stop_time
    if stop is not None and (
        isinstance(stop, bool)
        or not isinstance(stop, int | float)
        or not math.isfinite(stop)
        or stop <= config.start_time
    ):
        raise ConfigurationError(
            "stop_time", stop, f"None or a time after start_time ({config.start_time:g} s)"
        )
