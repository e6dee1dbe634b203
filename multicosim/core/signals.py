"""Signals: a trajectory as columns over strictly increasing times.

Requirements evaluate them ([`multicosim.search.requirements`][multicosim.search.requirements]) and
traces record them ([`multicosim.trace`][multicosim.trace]). A trajectory is a mapping of signal
name to values plus ``times`` (or a ``"time"`` entry), a sequence of msgspec Structs (or
dataclasses, or mappings) with a ``time`` field, whose numeric fields become signals (a rover
``Trajectory`` is one), or a NumPy structured array with a ``time`` field (an FMU's result, as FMPy
gives it).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import msgspec
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import ConfigurationError

__all__ = ["FloatArray", "Signals", "signals_of"]

FloatArray = NDArray[np.float64]


@dataclasses.dataclass(frozen=True)
class Signals:
    """A trajectory in columns: strictly increasing ``times`` and one array per signal."""

    times: FloatArray
    columns: Mapping[str, FloatArray]

    def __len__(self) -> int:
        return len(self.times)

    def at(self, time: float, names: Iterable[str]) -> dict[str, float]:
        """The values of ``names`` at ``time`` (held from the last sample at or before it)."""
        index = max(0, int(np.searchsorted(self.times, time, side="right")) - 1)
        return {name: float(self.columns[name][index]) for name in names}


def _numeric(value: object) -> bool:
    return isinstance(value, int | float | np.number) and not isinstance(value, str)


def signals_of(trajectory: object, *, times: ArrayLike | None = None) -> Signals:
    """Columns of ``trajectory`` (see the module docstring for the accepted shapes).

    Raises ConfigurationError for an empty trajectory, mismatched lengths, times that are
    not finite and strictly increasing, or a trajectory of another shape.
    """
    if isinstance(trajectory, Signals):
        return trajectory
    names = getattr(getattr(trajectory, "dtype", None), "names", None)
    if isinstance(trajectory, np.ndarray) and names:
        return _structured(trajectory, names, times)
    if isinstance(trajectory, Mapping):
        columns = {str(k): v for k, v in trajectory.items()}
        if times is None:
            if "time" not in columns:
                raise ConfigurationError(
                    "times", None, "sample times: pass times=... or a 'time' entry"
                )
            times = columns.pop("time")
        return _columns(times, columns)
    items = _sequence(trajectory)
    if items is None:
        raise ConfigurationError(
            "trajectory",
            trajectory,
            "a mapping of signal name to values, or a sequence of records with a 'time' field",
        )
    if not items:
        raise ConfigurationError("trajectory", trajectory, "at least one sample (it is empty)")
    records = [_record(item) for item in items]
    first = records[0]
    if times is None:
        if "time" not in first:
            raise ConfigurationError(
                "trajectory", type(items[0]).__name__, "records with a 'time' field"
            )
        times = [r["time"] for r in records]
    names = [k for k, v in first.items() if k != "time" and _numeric(v)]
    return _columns(times, {n: [r[n] for r in records] for n in names})


def _structured(array: np.ndarray, names: Sequence[str], times: ArrayLike | None) -> Signals:
    """A NumPy structured array (what fmpy.simulate_fmu and multicosim.fmi return): its
    ``time`` field is the times, each numeric field a signal; an array field ``y`` of shape
    (k,) becomes ``y[0]`` ... ``y[k-1]``."""
    if times is None:
        if "time" not in names:
            raise ConfigurationError(
                "times", None, "sample times: pass times=... or a 'time' field"
            )
        times = array["time"]
    columns: dict[str, Any] = {}
    for name in names:
        if name == "time" or array.dtype[name].base.kind not in "biuf":
            continue
        values = array[name]
        if values.ndim == 1:
            columns[name] = values
        else:
            flat = values.reshape(len(array), -1)
            columns.update({f"{name}[{i}]": flat[:, i] for i in range(flat.shape[1])})
    return _columns(times, columns)


def _sequence(trajectory: object) -> list[Any] | None:
    if isinstance(trajectory, str | bytes):
        return None
    if isinstance(trajectory, Sequence):
        return list(trajectory)
    samples = getattr(trajectory, "samples", None)  # e.g. rover.Trajectory
    if isinstance(samples, Sequence):
        return list(samples)
    return None


def _record(item: object) -> dict[str, Any]:
    if isinstance(item, msgspec.Struct):
        return {f: getattr(item, f) for f in item.__struct_fields__}
    if dataclasses.is_dataclass(item) and not isinstance(item, type):
        return {f.name: getattr(item, f.name) for f in dataclasses.fields(item)}
    if isinstance(item, Mapping):
        return dict(item)
    raise ConfigurationError(
        "trajectory", item, "samples that are msgspec Structs, dataclasses or mappings"
    )


def _columns(times: ArrayLike, columns: Mapping[str, ArrayLike]) -> Signals:
    t = np.asarray(times, dtype=np.float64)
    if t.ndim != 1 or len(t) == 0:
        raise ConfigurationError("trajectory", [], "at least one sample (it is empty)")
    if not np.all(np.isfinite(t)):
        raise ConfigurationError("times", t.tolist(), "finite sample times")
    if len(t) > 1 and not np.all(np.diff(t) > 0):
        bad = int(np.argmin(np.diff(t) > 0))
        raise ConfigurationError(
            "times",
            f"... {t[bad]:g}, {t[bad + 1]:g} ... (at index {bad + 1})",
            "strictly increasing sample times",
        )
    out: dict[str, FloatArray] = {}
    for name, values in columns.items():
        try:
            v = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            continue  # a non-numeric column (a state name, say): not a signal
        if v.shape != t.shape:
            raise ConfigurationError(
                f"trajectory[{name!r}]", f"{v.size} values", f"{len(t)} values, one per time"
            )
        out[name] = v
    return Signals(t, out)
