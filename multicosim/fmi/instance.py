"""One FMU instance, run through FMPy: instantiated, initialized, stepped, read and freed.

FMPy loads the binary and wraps every FMI call (a status above Warning raises its
``FMICallException``); this module only orders the calls as FMPy's own simulation loop does
(``fmpy.simulation.simulateCS`` / ``simulateME``) and keeps the per-step path cheap: value
references and value buffers are allocated once, each step makes one FMI call per type.
Model exchange FMUs are integrated with the solvers FMPy ships (SUNDIALS CVode, or forward
Euler), events handled as ``simulateME`` handles them.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from .errors import FMUError
from .model import Interface, Model, Variable

__all__ = ["STATUS", "Instance", "Reader"]

STATUS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")

# FMI type -> (ctypes element, getter suffix) for the buffers read every step.
_FMI2_TYPES: dict[str, tuple[Any, str]] = {
    "Real": (ctypes.c_double, "Real"),
    "Integer": (ctypes.c_int, "Integer"),
    "Enumeration": (ctypes.c_int, "Integer"),
    "Boolean": (ctypes.c_int, "Boolean"),
}
_FMI3_TYPES: dict[str, tuple[Any, str]] = {
    "Float32": (ctypes.c_float, "Float32"),
    "Float64": (ctypes.c_double, "Float64"),
    "Int8": (ctypes.c_int8, "Int8"),
    "UInt8": (ctypes.c_uint8, "UInt8"),
    "Int16": (ctypes.c_int16, "Int16"),
    "UInt16": (ctypes.c_uint16, "UInt16"),
    "Int32": (ctypes.c_int32, "Int32"),
    "UInt32": (ctypes.c_uint32, "UInt32"),
    "Int64": (ctypes.c_int64, "Int64"),
    "UInt64": (ctypes.c_uint64, "UInt64"),
    "Enumeration": (ctypes.c_int64, "Int64"),
    "Boolean": (ctypes.c_bool, "Boolean"),
}

Logger = Callable[[int, str, str], None]  # (status, category, message)


def _settable_instantiated(v: Variable) -> bool:
    # fmpy.simulation.settable_in_instantiated, on multicosim's Variable
    return v.causality == "input" or (
        v.variability != "constant" and v.initial in ("approx", "exact")
    )


def _settable_initialization(v: Variable) -> bool:
    # fmpy.simulation.settable_in_initialization_mode
    return (
        v.causality == "input"
        or (v.causality != "parameter" and v.variability == "tunable")
        or (v.variability != "constant" and v.initial == "exact")
    )


def settable(v: Variable) -> bool:
    """Whether a start value can be given to ``v`` (before or during initialization)."""
    return v.causality != "independent" and (
        _settable_instantiated(v) or _settable_initialization(v)
    )


class Reader:
    """Reads a fixed list of variables in one FMI call per type; values in list order.

    Arrays come back as flat lists (row-major, as FMI 3 stores them).
    """

    def __init__(self, fmu: Any, model: Model, variables: Sequence[Variable], shapes: Any) -> None:
        fmi3 = model.fmi_version.startswith("3")
        table = _FMI3_TYPES if fmi3 else _FMI2_TYPES
        self._count = len(variables)
        self._groups: list[
            tuple[Callable[..., Any], tuple[Any, ...], Any, list[tuple[int, int, int]], bool]
        ] = []
        self._slow: list[tuple[int, Callable[[], Any], bool]] = []
        by_kind: dict[str, list[tuple[int, Variable, int]]] = {}
        for position, v in enumerate(variables):
            size = math.prod(shapes(v)) if v.is_array else 1
            if v.type in table:
                by_kind.setdefault(table[v.type][1], []).append((position, v, size))
            else:  # strings and binaries: rare, read through FMPy's own getters
                self._slow.append((position, _slow_getter(fmu, v, size), v.is_array))
        component = fmu.component
        for suffix, members in by_kind.items():
            element = next(t for t, s in table.values() if s == suffix)
            vrs = (ctypes.c_uint * len(members))(*(v.value_reference for _, v, _ in members))
            total = sum(size for _, _, size in members)
            values = (element * total)()
            call = getattr(fmu, ("fmi3Get" if fmi3 else "fmi2Get") + suffix)
            args: tuple[Any, ...] = (component, vrs, len(members), values)
            if fmi3:
                args += (total,)
            slots: list[tuple[int, int, int]] = []
            offset = 0
            for position, v, size in members:
                slots.append((position, offset, size if v.is_array else 0))
                offset += size
            self._groups.append((call, args, values, slots, suffix == "Boolean" and not fmi3))
        # The common case, scalars of one type in order: the buffer is the answer.
        self._plain: tuple[Callable[..., Any], tuple[Any, ...], Any] | None = None
        if len(self._groups) == 1 and not self._slow:
            call, args, values, slots, as_bool = self._groups[0]
            if not as_bool and slots == [(i, i, 0) for i in range(self._count)]:
                self._plain = (call, args, values)

    def __call__(self) -> list[Any]:
        """The current values."""
        plain = self._plain
        if plain is not None:
            plain[0](*plain[1])
            values: list[Any] = plain[2][:]
            return values
        out: list[Any] = [None] * self._count
        for call, args, values, slots, as_bool in self._groups:
            call(*args)
            got = values[:]
            if as_bool:
                got = [v != 0 for v in got]
            for position, offset, size in slots:
                out[position] = got[offset : offset + size] if size else got[offset]
        for position, get, array in self._slow:
            found = get()
            out[position] = found if array else found[0]
        return out


def _slow_getter(fmu: Any, v: Variable, size: int) -> Callable[[], list[Any]]:
    vr = [v.value_reference]
    if v.type == "String":
        getter = fmu.getString
        if hasattr(fmu, "fmi3GetString"):
            return lambda: list(getter(vr, size))
        return lambda: [s.decode("utf-8") if isinstance(s, bytes) else s for s in getter(vr)]
    binary = fmu.getBinary
    return lambda: list(binary(vr, size))


class Instance:
    """An FMU instance of ``model`` in ``unzipdir`` through the ``interface`` asked for.

    ``on_log(status, category, message)`` receives the FMU's log messages (its logger
    callback), in the thread that makes the FMI call.
    """

    def __init__(
        self,
        model: Model,
        *,
        interface: Interface,
        unzipdir: str,
        name: str,
        debug_logging: bool,
        on_log: Logger,
    ) -> None:
        from fmpy.simulation import instantiate_fmu

        self.model = model
        self.name = name
        self.interface = interface
        self.fmi3 = model.fmi_version.startswith("3")
        self.time = 0.0
        self.terminated = False
        self._on_log = on_log
        self._solver: Any = None
        self._initialized = False
        self._freed = False
        self._structural: dict[int, int] = {}
        self._next_event: float | None = None
        try:
            self.fmu = instantiate_fmu(
                unzipdir,
                model.description,
                interface,
                debug_logging=debug_logging,
                logger=self._log3 if self.fmi3 else self._log2,
            )
        except Exception as exc:
            raise FMUError(name, model, "instantiate", str(exc), 0.0) from exc
        if self.fmi3 and interface == "CoSimulation":
            # doStep's results, allocated once and passed by reference every step.
            self._event = ctypes.c_bool()
            self._terminate = ctypes.c_bool()
            self._early = ctypes.c_bool()
            self._last = ctypes.c_double()
            self._step_refs = tuple(
                ctypes.byref(x) for x in (self._event, self._terminate, self._early, self._last)
            )

    # -- logging (called from C, inside FMI calls: never raise) -------------------------------

    def _log2(self, env: Any, instance: Any, status: int, category: Any, message: Any) -> None:
        self._on_log(int(status), _text(category), _text(message))

    def _log3(self, env: Any, status: int, category: Any, message: Any) -> None:
        self._on_log(int(status), _text(category), _text(message))

    # -- set-up ---------------------------------------------------------------------------

    def shape(self, v: Variable) -> tuple[int, ...]:
        """The shape of ``v`` with the structural parameters this instance was given."""
        if not v.is_array:
            return ()
        return tuple(
            size if size is not None else self._structural.get(vr or -1, 0)
            for size, vr in v.dimensions
        )

    def initialize(
        self,
        values: Mapping[str, Any],
        *,
        start_time: float,
        stop_time: float | None,
        tolerance: float | None,
        solver: str,
    ) -> None:
        """Set ``values`` (parameters and start values, by name) and initialize, as FMPy does.

        FMI 3 structural parameters are set first, in configuration mode.
        """
        fmu, model = self.fmu, self.model
        self.time = start_time
        pending = dict(values)
        for v in model.variables.values():
            if v.causality == "structuralParameter":
                self._structural[v.value_reference] = int(pending.get(v.name, v.start or 0))
        structural = [n for n in pending if model.variables[n].causality == "structuralParameter"]
        with self.calls("initialize"):
            if structural:
                fmu.enterConfigurationMode()
                for name in structural:
                    self._set(model.variables[name], pending.pop(name))
                fmu.exitConfigurationMode()
            if not self.fmi3:
                fmu.setupExperiment(
                    tolerance=tolerance if self.interface == "CoSimulation" else None,
                    startTime=start_time,
                    stopTime=stop_time,
                )
            self._set_where(pending, _settable_instantiated)
            if self.fmi3:
                fmu.enterInitializationMode(
                    tolerance=tolerance if self.interface == "CoSimulation" else None,
                    startTime=start_time,
                    stopTime=stop_time,
                )
            else:
                fmu.enterInitializationMode()
            self._set_where(pending, _settable_initialization)
            fmu.exitInitializationMode()
            self._initialized = True
            if self.interface == "ModelExchange":
                self._start_model_exchange(start_time, stop_time, tolerance, solver)

    def _set_where(self, pending: dict[str, Any], where: Callable[[Variable], bool]) -> None:
        for name in [n for n in pending if where(self.model.variables[n])]:
            self._set(self.model.variables[name], pending.pop(name))

    def setter(self, v: Variable) -> Callable[[Any], None]:
        """A function that sets ``v`` (a scalar, or a flat list for an array)."""
        fmu = self.fmu
        kind = "Int64" if self.fmi3 and v.type == "Enumeration" else v.type
        if not self.fmi3 and kind == "Enumeration":
            kind = "Integer"
        method = getattr(fmu, "set" + kind)
        vr = [v.value_reference]
        if v.is_array:
            return lambda value: method(vr, value)
        return lambda value: method(vr, [value])

    def _set(self, v: Variable, value: Any) -> None:
        self.setter(v)(value)

    def reader(self, variables: Sequence[Variable]) -> Reader:
        """A ``Reader`` of ``variables``."""
        return Reader(self.fmu, self.model, variables, self.shape)

    # -- model exchange -------------------------------------------------------------------

    def _start_model_exchange(
        self, start_time: float, stop_time: float | None, tolerance: float | None, solver: str
    ) -> None:
        from fmpy.simulation import ForwardEuler, Input

        fmu, md = self.fmu, self.model.description
        self._event_iteration()
        fmu.enterContinuousTimeMode()
        args = {
            "nx": md.numberOfContinuousStates,
            "nz": md.numberOfEventIndicators,
            "get_x": fmu.getContinuousStates,
            "set_x": fmu.setContinuousStates,
            "get_dx": fmu.getContinuousStateDerivatives if self.fmi3 else fmu.getDerivatives,
            "get_z": fmu.getEventIndicators,
            # Inputs come from topics and are held over a period: FMPy's input table is empty.
            "input": Input(fmu, md, None),
        }
        if solver == "Euler":
            self._solver = ForwardEuler(**args)
        else:
            from fmpy.sundials import CVodeSolver

            horizon = (stop_time - start_time) if stop_time is not None else math.inf
            self._solver = CVodeSolver(
                get_nominals=fmu.getNominalsOfContinuousStates,
                set_time=fmu.setTime,
                startTime=start_time,
                maxStep=horizon / 50.0,  # what fmpy.simulate_fmu gives CVode
                relativeTolerance=tolerance if tolerance is not None else 1e-5,
                **args,
            )

    def _event_iteration(self) -> bool:
        """Update discrete states until they settle; True if the FMU asks to terminate."""
        update = self.fmu.updateDiscreteStates if self.fmi3 else self.fmu.newDiscreteStates
        needed, terminate = True, False
        while needed and not terminate:
            needed, terminate, _, _, defined, when = update()
            self._next_event = when if defined else None
        return bool(terminate)

    def _integrate(self, time: float, until: float) -> None:
        fmu = self.fmu
        needs_completed = self.model.description.modelExchange.needsCompletedIntegratorStep
        while time < until and not math.isclose(time, until):
            point = until
            next_event = self._next_event
            if (
                next_event is not None
                and point > next_event
                and not math.isclose(point, next_event)
            ):
                point = next_event
            time_event = next_event is not None and math.isclose(point, next_event)
            state_event, _, time = self._solver.step(time, point)
            fmu.setTime(time)
            step_event = False
            if needs_completed:
                step_event, terminate = fmu.completedIntegratorStep()
                if terminate:
                    self.terminated = True
                    return
            if time_event or state_event or step_event:
                fmu.enterEventMode()
                if self._event_iteration():
                    self.terminated = True
                    return
                fmu.enterContinuousTimeMode()
                self._solver.reset(time)

    # -- stepping -------------------------------------------------------------------------

    def advance(self, time: float, until: float) -> None:
        """Advance from communication point ``time`` to ``until`` (doStep, or integrate).

        Sets ``terminated`` if the FMU asks to end the simulation. FMPy raises for a
        status above Warning: the caller turns that into FMUError with ``failure``.
        """
        if self.interface == "ModelExchange":
            self._integrate(time, until)
        elif self.fmi3:
            self.fmu.fmi3DoStep(self.fmu.component, time, until - time, True, *self._step_refs)
            if self._terminate.value:
                self.terminated = True
        else:
            try:
                self.fmu.fmi2DoStep(self.fmu.component, time, until - time, 1)
            except Exception as exc:
                # Discard with the terminated status is how an FMI 2 FMU ends the run at its
                # last successful time (fmpy.simulate_fmu ends there too); anything else fails.
                if getattr(exc, "status", None) != 2 or not self.fmu.getBooleanStatus(3):
                    raise
                self.terminated = True
                self.time = self.fmu.getRealStatus(2)  # fmi2LastSuccessfulTime
                return
        self.time = until

    def calls(self, what: str, time: float | None = None) -> _Calls:
        """A context in which FMPy's failures become FMUError (the instance is then freed)."""
        return _Calls(self, what, self.time if time is None else time)

    def failure(
        self, exc: Exception, what: str, time: float, simulated: float | None = None
    ) -> FMUError:
        """The FMUError that FMPy's exception ``exc`` (or the solver's) stands for, at the
        FMU's ``time`` and the ``simulated`` time (default: the same); the instance is freed
        (after Fatal only abandoned, as FMI requires)."""
        from fmpy.fmi1 import FMICallException

        if isinstance(exc, FMICallException):
            function = exc.function
            status = STATUS[exc.status] if 0 <= exc.status < len(STATUS) else str(exc.status)
        else:  # the solver (CVode) or FMPy itself
            function, status = what, f"{type(exc).__name__}: {exc}"
        self.abandon(status)
        at = time if simulated is None else simulated
        return FMUError(self.name, self.model, function, status, at, fmu_time=time)

    # -- the end --------------------------------------------------------------------------

    def close(self) -> None:
        """Terminate (if it ran without error) and free the instance; idempotent."""
        if self._freed:
            return
        self._freed = True
        self._solver = None
        try:
            if self._initialized:
                self.fmu.terminate()
        except Exception as exc:  # an FMU that fails to terminate is still freed
            self._on_log(3, "multicosim", f"terminate failed: {exc}")
        finally:
            self.fmu.freeInstance()

    def abandon(self, status: str) -> None:
        """After an error: free the instance without terminating it (nothing after Fatal)."""
        if self._freed:
            return
        self._freed = True
        self._solver = None
        if status != "Fatal":  # FMI: after Fatal no function may be called, not even free
            try:
                self.fmu.freeInstance()
            except Exception as exc:
                self._on_log(3, "multicosim", f"freeInstance failed: {exc}")


class _Calls:
    """Turns FMPy's exceptions inside it into FMUError (function, status, time); frees."""

    def __init__(self, instance: Instance, what: str, time: float) -> None:
        self.instance = instance
        self.what = what
        self.time = time

    def __enter__(self) -> None:
        return None

    def __exit__(self, tp: Any, exc: BaseException | None, tb: Any) -> None:
        if exc is None or not isinstance(exc, Exception) or isinstance(exc, FMUError):
            return
        raise self.instance.failure(exc, self.what, self.time) from exc


def _text(value: Any) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    return "" if value is None else str(value)
