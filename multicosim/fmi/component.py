"""An FMU as a component: [`FMU`][multicosim.fmi.component.FMU] (the configuration, checked on
construction) and the [`FMUNode`][multicosim.fmi.component.FMUNode] it starts where its placement
runs it (this process, a local process, a container, ...)."""

from __future__ import annotations

import dataclasses
import os
import re
import weakref
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import msgspec
import numpy as np

from ..core.clock import Delivery, Scheduler
from ..core.errors import ConfigurationError, MulticosimError
from ..core.interfaces import Component, Node
from ..core.messages import decode
from ..local import LocalEnvironment, required_images
from ..local.waits import DEFAULT_START_TIMEOUT, check_timeout
from ..placement import ParticipantProgram, Placement, as_placement
from .build import IN_IMAGE, build_image, image_entry, no_binary, prepare
from .config import (
    PARAMETERS,
    SETTABLE,
    SOLVERS,
    FMUConfig,
    Plan,
    Solver,
    check_values,
    plan,
    shapes_of,
)
from .messages import LogLine, result_dtype
from .model import INTERFACES, Interface, Model, describe
from .participant import PROGRAM, FMUParticipant

if TYPE_CHECKING:
    from ..trace import TraceOptions

__all__ = ["FMU", "FMUNode", "default_name"]


@dataclasses.dataclass(frozen=True)
class FMU:
    """An FMU (FMI 2.0 or 3.0) as a component, checked against its model description:

    ```python
    fmi.FMU("plant.fmu", name="plant", period=0.01, parameters={"e": 0.7},
            inputs={"u": "cmd"}, outputs={"y": "state"})
    ```

    ``inputs`` maps input variables to the topics they are read from, ``outputs`` output
    variables (or locals named in ``record``) to the topics they are published on; every
    step the component also publishes its record (time, every output and the ``record``
    variables) on the topic named like it. ``parameters`` and ``start_values`` set
    variables by name before the run (arrays as nested or flat sequences). ``period`` is
    the communication step (default: the FMU's own,
    [`Model.default_step`][multicosim.fmi.Model.default_step]).

    ``placement`` is where it runs: ``"in-process"`` (fastest), ``"process"`` (a crash or
    abort in the FMU's native code is a NodeCrashedError, not the end of the test process),
    ``"docker"`` (a container: its image, the runtime image with the FMU copied in, is
    built on start unless ``image`` names one) or any registered placement. ``interface`` picks
    co-simulation or model exchange (default: co-simulation when the FMU has it); model
    exchange is integrated with FMPy's ``solver`` (``"CVode"`` or ``"Euler"``).
    ``start_time`` is the FMU's time when the simulation starts; ``stop_time`` is told to
    the FMU and it does not step past it. ``compile`` builds a binary from the FMU's C sources
    (with FMPy and a C compiler) when it has none for this platform. ``history`` keeps
    every record for [`FMUNode.result`][multicosim.fmi.component.FMUNode.result].
    """

    path: str | os.PathLike[str]
    name: str | None = None
    period: float | None = None
    parameters: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    start_values: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    inputs: Mapping[str, str] = dataclasses.field(default_factory=dict)
    outputs: Mapping[str, str] = dataclasses.field(default_factory=dict)
    record: Sequence[str] = ()
    placement: str | Placement = "in-process"
    interface: Interface | None = None
    solver: Solver = "CVode"
    tolerance: float | None = None
    start_time: float = 0.0
    stop_time: float | None = None
    compile: bool = False
    debug_logging: bool = False
    image: str | None = None
    history: bool = True
    start_timeout: float = DEFAULT_START_TIMEOUT

    def __post_init__(self) -> None:
        model = describe(self.path)
        as_placement(self.placement)
        if not model.runnable_here and not self.compile:
            raise ConfigurationError("path", str(self.path), no_binary(model))
        if self.compile and not model.runnable_here and not model.has_sources:
            raise ConfigurationError(
                "compile", True, f"an FMU with C sources to compile ({model.label} has none)"
            )
        name = self.name if self.name is not None else default_name(model)
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
            raise ConfigurationError(
                "name", name, "a component name of letters, digits, '_', '.' and '-'"
            )
        interface = self.interface or model.interfaces[0]
        if interface not in INTERFACES:
            raise ConfigurationError("interface", interface, f"one of {INTERFACES}")
        period = self.period if self.period is not None else model.default_step
        if period is None:
            raise ConfigurationError(
                "period", None, f"a period in seconds ({model.label} states no default step)"
            )
        if self.solver not in SOLVERS:
            raise ConfigurationError("solver", self.solver, f"one of {SOLVERS} (FMPy's solvers)")
        check_timeout("start_timeout", self.start_timeout)
        shapes = shapes_of(model, self.parameters, "parameters")
        parameters = check_values(model, self.parameters, "parameters", *PARAMETERS, shapes=shapes)
        others = (c for c in SETTABLE if c not in PARAMETERS)
        starts = check_values(model, self.start_values, "start_values", *others, shapes=shapes)
        for field in ("inputs", "outputs"):
            mapping = getattr(self, field)
            if not isinstance(mapping, Mapping):
                raise ConfigurationError(field, mapping, "a mapping of variable name to topic")
        if isinstance(self.record, str) or not isinstance(self.record, Sequence):
            raise ConfigurationError("record", self.record, "a sequence of variable names")
        if self.image is not None and (not isinstance(self.image, str) or not self.image):
            raise ConfigurationError("image", self.image, "None or a local image name")
        config = FMUConfig(
            path=str(model.path),
            name=name,
            period=float(period),
            interface=interface,
            values={**parameters, **starts},
            inputs=dict(self.inputs),
            outputs=dict(self.outputs),
            record=tuple(self.record),
            solver=self.solver,
            tolerance=self.tolerance,
            start_time=self.start_time,
            stop_time=self.stop_time,
            debug_logging=bool(self.debug_logging),
        )
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "_plan", plan(config, model))

    @property
    def model(self) -> Model:
        """The FMU's model description (the contract)."""
        return self.plan.model

    @property
    def plan(self) -> Plan:
        """The configuration resolved against the model description."""
        resolved: Plan = self.__dict__["_plan"]
        return resolved

    @property
    def config(self) -> FMUConfig:
        """What the participant program runs."""
        return self.plan.config

    def replace(self, **changes: Any) -> FMU:
        """A copy with ``changes`` (checked again), e.g. ``fmu.replace(placement="process")``."""
        return dataclasses.replace(self, **changes)

    def _program(self, build: Any = None) -> ParticipantProgram:
        plan_ = self.plan
        return ParticipantProgram(
            PROGRAM,
            plan_.config,
            plan_.config.name,
            build=build,
            local_config=lambda environment: self._local_config(environment, plan_),
            image=self._image,
            images=(self.image,) if self.image is not None else (),
            start_timeout=self.start_timeout,
        )

    def _placed(self) -> Component[Any, Node]:
        return as_placement(self.placement).participant(self._program())

    def required_images(self) -> tuple[str, ...]:
        """The images its placement needs: ``image`` if given (otherwise one is built)."""
        return tuple(required_images(self._placed()))

    def start(self, environment: LocalEnvironment) -> FMUNode:
        """Start the FMU where it is placed; it steps from the current instant."""
        plan_ = self.plan
        placement = as_placement(self.placement)
        if placement.in_process:
            built: list[FMUParticipant] = []

            def build(environment: LocalEnvironment) -> FMUParticipant:
                built.append(self._participant(environment, plan_))
                return built[0]

            node = placement.participant(self._program(build)).start(environment)
            records = built[0].history if self.history else None
            return FMUNode(
                plan_.config.name, placement.name, node, plan_, records, built[0].log_lines
            )
        # What another process publishes is kept from the scheduler's traffic.
        collector = _collector(environment.scheduler)
        kept = collector.watch(plan_.topic) if self.history else None
        lines = collector.watch(plan_.log_topic)
        try:
            node = self._placed().start(environment)
        except BaseException:
            collector.forget(plan_.topic, plan_.log_topic)
            raise
        return FMUNode(plan_.config.name, placement.name, node, plan_, kept, lines)

    def _local_config(self, environment: LocalEnvironment, plan_: Plan) -> FMUConfig:
        """The configuration for this machine: the FMU extracted (and compiled) in the run."""
        config = plan_.config
        workdir = environment.run_dir / f"{config.name}.fmu.d"
        path = config.path
        if not plan_.model.runnable_here:
            path = str(prepare(plan_.model, workdir))
        return msgspec.structs.replace(config, path=path, workdir=str(workdir))

    def _participant(self, environment: LocalEnvironment, plan_: Plan) -> FMUParticipant:
        """The participant in this process: its log kept, and its history if asked."""
        config = msgspec.structs.replace(
            self._local_config(environment, plan_),
            log_file=str(environment.run_dir / f"{plan_.config.name}.log"),
        )
        return FMUParticipant(
            config,
            dataclasses.replace(plan_, config=config),
            keep_log=True,
            keep_history=self.history,
        )

    def _image(self) -> tuple[str, FMUConfig]:
        """The image a container runs it from (built unless given) and its configuration."""
        plan_ = self.plan
        image = self.image or build_image(plan_.model.path, compile=self.compile)
        inside = f"{IN_IMAGE}/{image_entry(plan_.model)}"
        return image, msgspec.structs.replace(plan_.config, path=inside)


class FMUNode:
    """A running FMU component: its node where it runs, and what it published.

    [`result`][multicosim.fmi.component.FMUNode.result] gives the recorded variables as
    fmpy.simulate_fmu gives them (a NumPy structured array: ``time``, then the numbers and
    booleans); [`log`][multicosim.fmi.component.FMUNode.log] the FMU's own log messages;
    [`trace_options`][multicosim.fmi.component.FMUNode.trace_options] tells a trace recorder the
    types and units of its channels. ``node`` is the underlying in-process, process or container
    node.
    """

    def __init__(
        self,
        name: str,
        placement: str,
        node: Node,
        plan: Plan,
        records: list[Any] | None,
        lines: list[Any] | None,
    ) -> None:
        self.name = name
        self.placement = placement
        """The name of the placement it runs in."""
        self.node = node
        self.plan = plan
        self._records = records
        self._lines = lines

    def parts(self) -> list[Node]:
        """The node that runs it."""
        return [self.node]

    @property
    def model(self) -> Model:
        """The FMU's model description."""
        return self.plan.model

    @property
    def topic(self) -> str:
        """The topic of its record (its name)."""
        return self.plan.topic

    def records(self) -> list[Any]:
        """Every record published so far, typed (see ``multicosim.fmi.messages``)."""
        if self._records is None:
            raise MulticosimError(f"FMU {self.name!r} keeps no history (history=False)")
        return _typed(self._records, self.plan.record_type, f"{self.name}'s record")

    def result(self, variables: Sequence[str] | None = None) -> Any:
        """The records as fmpy.simulate_fmu returns its result: a ``SimulationResult`` with
        ``time`` and the recorded numbers and booleans (or only ``variables``), in FMPy's
        column order."""
        from fmpy.simulation import SimulationResult

        plan_ = self.plan
        recorded = {v.name: i for i, v in enumerate(plan_.recorded, start=1)}
        if variables is not None:
            for name in variables:
                if name not in recorded:
                    raise ConfigurationError(
                        "variables", name, f"a recorded variable: one of {sorted(recorded)}"
                    )
        wanted = [v for v in plan_.recorded if variables is None or v.name in variables]
        rows = [msgspec.structs.astuple(r) for r in self.records()]
        dtype = result_dtype(plan_.model, wanted, plan_.shapes)
        result = np.zeros(len(rows), dtype=dtype)
        result["time"] = [r[0] for r in rows]
        for v in wanted:
            if v.name in (dtype.names or ()):  # numbers and booleans, as FMPy records them
                i = recorded[v.name]
                shape = plan_.shapes.get(v.name, ())
                values = np.asarray([r[i] for r in rows], dtype=dtype[v.name].base)
                result[v.name] = values.reshape((len(rows), *shape))
        view = result.view(SimulationResult)
        view.modelDescription = plan_.model.description
        return view

    def log(self) -> list[LogLine]:
        """The FMU's log messages so far (its logger callback), oldest first."""
        return _typed(self._lines or [], LogLine, f"{self.name}'s log")

    def trace_options(self) -> TraceOptions:
        """Its channels for a trace: the record's type (schema from the model description,
        units included), the log as ``foxglove.Log``, a plot of its outputs."""
        from ..trace import TraceOptions, message_path

        plan_ = self.plan
        scalars = [
            v.name
            for v in plan_.recorded
            if v.causality == "output" and not v.is_array and v.python_type in (float, int, bool)
        ]
        plots = [(f"FMU {self.name}", [message_path(plan_.topic, n) for n in scalars[:6]])]
        return TraceOptions(
            types={plan_.topic: plan_.record_type, plan_.log_topic: LogLine},
            converters=(_LogChannel(plan_.log_topic, self.name),),
            replaced=(plan_.log_topic,),
            plots=plots if scalars else (),
        )

    def stop(self) -> None:
        """Stop it where it runs (the instance is freed, extracted files removed)."""
        self.node.stop()

    def __repr__(self) -> str:
        return f"FMUNode({self.name!r}, placement={self.placement!r}, model={self.model.name!r})"


def _typed(kept: list[Any], tp: Any, what: str) -> list[Any]:
    """Messages kept in this process (objects) or from a scheduler's traffic (deliveries)."""
    return [
        d if type(d) is tp else d.obj if type(d.obj) is tp else decode(d.data, tp, what=what)
        for d in kept
    ]


@dataclasses.dataclass(frozen=True)
class _LogChannel:
    """The FMU's log messages as a ``foxglove.Log`` channel (Foxglove's Log panel)."""

    topic: str
    name: str

    @property
    def topics(self) -> tuple[str, ...]:
        return (self.topic,)

    def __call__(self, topic: str, time_ns: int, message: Any) -> Iterable[Any]:
        from ..trace import LOG, Converted, stamp

        level = {"OK": 2, "Warning": 3, "Discard": 3, "Error": 4, "Fatal": 5}.get(
            str(message.get("status")), 2
        )
        return (
            Converted(
                self.topic,
                LOG,
                {
                    "timestamp": stamp(time_ns),
                    "level": level,
                    "message": str(message.get("message", "")),
                    "name": self.name,
                    "file": str(message.get("category", "")),
                    "line": 0,
                },
            ),
        )


# -- what the FMUs of one simulation published -------------------------------------------------


class _Collector:
    """One scheduler tap for every FMU of a simulation: keeps the deliveries of some topics."""

    def __init__(self) -> None:
        self.topics: dict[str, list[Delivery]] = {}

    def __call__(self, delivery: Delivery) -> None:
        kept = self.topics.get(delivery.topic)
        if kept is not None:
            kept.append(delivery)

    def watch(self, topic: str) -> list[Delivery]:
        return self.topics.setdefault(topic, [])

    def forget(self, *topics: str) -> None:
        for topic in topics:
            self.topics.pop(topic, None)


_collectors: weakref.WeakKeyDictionary[Scheduler, _Collector] = weakref.WeakKeyDictionary()


def _collector(scheduler: Scheduler) -> _Collector:
    found = _collectors.get(scheduler)
    if found is None:
        found = _collectors[scheduler] = _Collector()
        scheduler.taps.append(found)
    return found


def default_name(model: Model) -> str:
    """The name an FMU component gets unless given one: its file's stem."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", model.path.stem) or "fmu"
