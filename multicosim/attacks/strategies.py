"""Hypothesis strategies for sensor attacks: models, their timing, whole attack lists.

Every strategy shrinks towards the harmless case (zero noise, zero offset, no model), so a
failure Hypothesis reports is the smallest attack that still breaks the requirement:

```python
from hypothesis import given
from multicosim.attacks import strategies as ast

@given(ast.jumps(offset=(0.0, 30.0), start=(5.0, 20.0)))
def test_spoof(mcs_fresh_simulation, jump): ...
```

Bounds are checked when the strategy is built (ConfigurationError naming the argument).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from hypothesis import strategies as st

from ..core.errors import ConfigurationError
from ..search.strategies import Range, check_range
from .models import AXES, Bias, Delay, Drift, Dropout, Gaussian, Jump, Local, Model
from .sensors import sensor

__all__ = [
    "attacks",
    "biases",
    "delays",
    "drifts",
    "dropouts",
    "gaussians",
    "jumps",
    "offsets",
]


def _size(size: int) -> int:
    if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= 16:
        raise ConfigurationError("axes", size, "a number of axes in [1, 16]")
    return size


def _towards_zero(lo: float, hi: float) -> st.SearchStrategy[float]:
    # Hypothesis shrinks floats towards 0 when the range allows it; otherwise start at lo.
    values = st.floats(lo, hi)
    return st.one_of(st.just(0.0), values) if lo <= 0.0 <= hi else values


def offsets(
    magnitude: Range, *, axes: int | Sequence[str] = 3
) -> st.SearchStrategy[tuple[float, ...] | Local]:
    """A vector of ``axes`` numbers whose length lies in ``magnitude`` (shrinks to the lowest).

    The direction is uniform (on the circle or sphere for 2 or 3 axes); one axis gives a
    signed number. ``axes`` given by name (a quantity's) for a local position gives a
    [`Local`][multicosim.attacks.Local].
    """
    if not isinstance(axes, int) and sorted(axes) == sorted(AXES):
        return _vectors(magnitude, 3).map(lambda v: Local(**dict(zip(AXES, v, strict=True))))
    return _vectors(magnitude, _size(axes if isinstance(axes, int) else len(axes)))


def _vectors(magnitude: Range, n: int) -> st.SearchStrategy[tuple[float, ...]]:
    lo, hi = check_range("magnitude", magnitude, low=0.0, high=1e7)
    length = _towards_zero(lo, hi)
    if n == 1:
        return st.builds(lambda r, sign: (r * sign,), length, st.sampled_from((1.0, -1.0)))
    direction = st.lists(st.floats(-1.0, 1.0), min_size=n, max_size=n).filter(
        lambda v: math.fsum(x * x for x in v) > 1e-6
    )

    def build(r: float, v: list[float]) -> tuple[float, ...]:
        norm = math.sqrt(math.fsum(x * x for x in v))
        return tuple(r * x / norm for x in v)

    return st.builds(build, length, direction)


def _times(start: Range, duration: Range | None) -> st.SearchStrategy[tuple[float, float | None]]:
    s_lo, s_hi = check_range("start", start, low=0.0, high=1e6)
    begin = st.floats(s_lo, s_hi)
    if duration is None:
        return st.tuples(begin, st.none())
    d_lo, d_hi = check_range("duration", duration, low=0.0, high=1e6, low_open=True)
    return st.tuples(begin, st.floats(d_lo, d_hi)).map(lambda p: (p[0], p[0] + p[1]))


def gaussians(
    std: Range = (0.0, 2.0), *, start: Range = (0.0, 0.0), on: str | None = None
) -> st.SearchStrategy[Gaussian]:
    """White noise with a standard deviation in ``std`` (same on every axis)."""
    lo, hi = check_range("std", std, low=0.0, high=1e6)
    return st.builds(
        lambda s, t: Gaussian(std=s, start=t[0], end=t[1], on=on),
        _towards_zero(lo, hi),
        _times(start, None),
    )


def biases(
    magnitude: Range = (0.0, 5.0),
    *,
    axes: int | Sequence[str] = 3,
    start: Range = (0.0, 0.0),
    on: str | None = None,
) -> st.SearchStrategy[Bias]:
    """A constant offset of length in ``magnitude``."""
    return st.builds(
        lambda v, t: Bias(offset=v, start=t[0], end=t[1], on=on),
        offsets(magnitude, axes=axes),
        _times(start, None),
    )


def drifts(
    std: Range = (0.0, 1.0), *, start: Range = (0.0, 0.0), on: str | None = None
) -> st.SearchStrategy[Drift]:
    """A random walk with diffusion in ``std`` (units per square-root second)."""
    lo, hi = check_range("std", std, low=0.0, high=1e6)
    return st.builds(
        lambda s, t: Drift(std=s, start=t[0], end=t[1], on=on),
        _towards_zero(lo, hi),
        _times(start, None),
    )


def jumps(
    magnitude: Range = (0.0, 20.0),
    *,
    axes: int | Sequence[str] = 3,
    start: Range = (0.0, 30.0),
    ramp: Range = (0.0, 0.0),
    on: str | None = None,
) -> st.SearchStrategy[Jump]:
    """A spoof: an offset of length in ``magnitude`` from a ``start`` time, over ``ramp`` s."""
    r_lo, r_hi = check_range("ramp", ramp, low=0.0, high=1e6)
    return st.builds(
        lambda v, t, r: Jump(offset=v, start=t[0], end=t[1], ramp=r, on=on),
        offsets(magnitude, axes=axes),
        _times(start, None),
        _towards_zero(r_lo, r_hi),
    )


def dropouts(
    start: Range = (0.0, 30.0), duration: Range = (0.1, 10.0)
) -> st.SearchStrategy[Dropout]:
    """No readings for ``duration`` seconds from ``start``; shrinks to the shortest, earliest."""
    return _times(start, duration).map(lambda t: Dropout(start=t[0], end=t[1]))


def delays(
    delay: Range = (0.0, 1.0), *, start: Range = (0.0, 0.0), duration: Range | None = None
) -> st.SearchStrategy[Delay]:
    """Readings held back by a delay in ``delay`` seconds."""
    lo, hi = check_range("delay", delay, low=0.0, high=1e6)
    return st.builds(
        lambda d, t: Delay(delay=d, start=t[0], end=t[1]),
        _towards_zero(lo, hi),
        _times(start, duration),
    )


def attacks(
    vehicle: str = "px4",
    sensor_name: str = "gps",
    *,
    kinds: Sequence[str] = ("gaussian", "bias", "drift", "jump", "dropout", "delay"),
    max_models: int = 3,
    magnitude: Range = (0.0, 10.0),
    start: Range = (0.0, 30.0),
) -> st.SearchStrategy[list[Model]]:
    """Lists of up to ``max_models`` models that fit ``sensor_name`` of ``vehicle``.

    Additive models act on the sensor's default quantity with sizes in ``magnitude`` (a
    standard deviation, an offset's length); shrinks towards the empty list (no attack).
    """
    spec = sensor(vehicle, sensor_name)
    axes = spec.quantities[spec.default].axes
    lo, hi = check_range("magnitude", magnitude, low=0.0, high=1e7)
    allowed = ("gaussian", "bias", "drift", "jump", "dropout", "delay")
    chosen = tuple(kinds)
    if not chosen or isinstance(kinds, str) or any(k not in allowed for k in chosen):
        raise ConfigurationError("kinds", kinds, f"a non-empty list drawn from {allowed}")
    if isinstance(max_models, bool) or not isinstance(max_models, int) or not max_models >= 1:
        raise ConfigurationError("max_models", max_models, "an integer >= 1")
    strategies: dict[str, st.SearchStrategy[Model]] = {
        "gaussian": gaussians((lo, hi), start=start),
        "bias": biases((lo, hi), axes=axes, start=start),
        "drift": drifts((lo, hi), start=start),
        "jump": jumps((lo, hi), axes=axes, start=start),
        "dropout": dropouts(start),
        "delay": delays((0.0, 1.0), start=start),
    }
    one = st.one_of(*(strategies[k] for k in chosen))
    return st.lists(one, max_size=max_models)
