"""``fmi.simulate``: one FMU alone through the lockstep, returning what FMPy returns."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

from ..core.errors import ConfigurationError
from ..placement import Placement, as_placement
from .component import FMU, default_name
from .config import PARAMETERS, Solver
from .model import Interface, Model, describe

__all__ = ["default_step", "simulate"]


def simulate(
    path: str | os.PathLike[str],
    stop_time: float | None = None,
    step: float | None = None,
    parameters: Mapping[str, Any] | None = None,
    *,
    start_values: Mapping[str, Any] | None = None,
    output: Sequence[str] | None = None,
    start_time: float | None = None,
    fmi_type: Interface | None = None,
    solver: Solver = "CVode",
    relative_tolerance: float | None = None,
    placement: str | Placement = "in-process",
    simulator: Any = None,
) -> Any:
    """Simulate the FMU at ``path`` alone, on multicosim's clock, like fmpy.simulate_fmu.

    Returns what ``fmpy.simulate_fmu`` returns: a structured NumPy array (an FMPy
    ``SimulationResult``) with ``time`` and the outputs (or the variables named in
    ``output``), one row per communication point from ``start_time`` to ``stop_time``.
    Defaults are FMPy's: the default experiment's start and stop time, and a step of the
    FMU's fixed internal step or its default experiment's step size (doubled until at most
    1000 steps), else FMPy's ``auto_interval``. ``start_values`` (FMPy's name) may hold
    parameters too; ``parameters`` holds only parameters. ``placement`` is where the FMU
    runs (in-process, as a process, in a container, ...); ``simulator`` is an unstarted
    simulator to run in (default: a new one of that placement).
    """
    model = describe(path)
    start = float(start_time if start_time is not None else (model.start_time or 0.0))
    stop = float(
        stop_time
        if stop_time is not None
        else (model.stop_time if model.stop_time is not None else start + 1.0)
    )
    interface = fmi_type or model.interfaces[0]
    if interface not in model.interfaces:
        raise ConfigurationError("fmi_type", interface, f"one of {model.interfaces}")
    period = step if step is not None else default_step(model, interface, start, stop)
    given = {**(start_values or {})}
    params = {**{k: v for k, v in given.items() if _is_parameter(model, k)}, **(parameters or {})}
    starts = {k: v for k, v in given.items() if not _is_parameter(model, k)}
    names = list(output) if output is not None else _default_output(model)
    fmu = FMU(
        path,
        name=default_name(model),
        period=period,
        parameters=params,
        start_values=starts,
        record=[
            n
            for n in names
            if model.variables.get(n) is None or model.variables[n].causality != "output"
        ],
        placement=placement,
        interface=interface,
        solver=solver,
        tolerance=relative_tolerance,
        start_time=start,
        stop_time=stop,
    )
    if simulator is None:
        simulator = as_placement(placement).simulator()
    node_id = simulator.add(fmu)
    points = math.ceil((stop - start) / fmu.config.period - 1e-9)
    with simulator.start() as simulation:
        # Every communication point up to the stop time is due before this.
        simulation.advance((points + 0.5) * fmu.config.period)
        return simulation.get(node_id).result(names)


def default_step(model: Model, interface: Interface, start: float, stop: float) -> float:
    """The output interval fmpy.simulate_fmu would take for ``model`` from start to stop."""
    from fmpy.util import auto_interval

    total = stop - start
    if interface == "ModelExchange":
        # FMPy's solver step for model exchange, which becomes its output interval.
        step: float | None = 10 ** (round(math.log10(total)) - 3)
    else:
        step = model.default_step
        if step is None:
            return float(auto_interval(total))
    assert step is not None
    while total / step > 1000:
        step *= 2
    return float(step)


def _is_parameter(model: Model, name: str) -> bool:
    v = model.variables.get(name)
    return v is not None and v.causality in PARAMETERS


def _default_output(model: Model) -> list[str]:
    # fmpy.simulation's choice when no output is named: the outputs, else (at most five)
    # continuous states, else locals.
    outputs = [v.name for v in model.of("output")]
    if outputs:
        return outputs
    states = [
        u.variable.derivative.name for u in model.description.derivatives if u.variable.derivative
    ]
    if states:
        return states[:5]
    return [v.name for v in model.of("local")][:5]
