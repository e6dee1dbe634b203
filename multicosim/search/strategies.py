"""Hypothesis strategies for simulations, and a fresh simulation per generated example.

```python
from hypothesis import given
import multicosim.search.strategies as mst

@given(world=mst.world_configs(iterations=(10, 200)), speed=st.floats(1.0, 10.0))
def test_rover(mcs_fresh_simulation, world, speed):
    with mcs_fresh_simulation(rover.Rover, world=world) as sim:
        trajectory = sim.controller.send(rover.Mission(speed=speed))
    mst.target_robustness(requirement.evaluate(trajectory))
    requirement.check(trajectory)
```

These are the strategies every scenario shares; a scenario's own (missions, waypoints) are in
its package (``multicosim.rover.strategies``, ``multicosim.px4.strategies``), with the same
conventions: ranges are ``(low, high)`` tuples, checked when the strategy is built (an
inverted range, or one outside what the configuration accepts, raises ConfigurationError
naming the argument), and every strategy shrinks towards the simple case: the lowest
fidelity, the default world, zero noise, no obstacles, still air.
"""

from __future__ import annotations

import contextlib
import inspect
import math
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from ..core.deps import require
from ..core.errors import ConfigurationError
from ..core.fidelity import FIDELITIES, check_fidelity

require("hypothesis", "hypothesis")

import hypothesis  # noqa: E402 - after the dependency check, which names the extra
from hypothesis import strategies as st  # noqa: E402

if TYPE_CHECKING:
    from ..physics import Obstacle, Wind, WorldConfig
    from .requirements import Evaluation

__all__ = [
    "FreshSimulations",
    "check_range",
    "fidelities",
    "noise_levels",
    "obstacles",
    "simple_first",
    "target_robustness",
    "winds",
    "world_configs",
]

T = TypeVar("T")
Range = tuple[float, float]


def check_range(
    name: str,
    bounds: Sequence[float],
    *,
    low: float,
    high: float,
    low_open: bool = False,
    integer: bool = False,
) -> tuple[float, float]:
    """Validate ``bounds`` = (lo, hi) inside [low, high] (``low_open``: lo > low)."""
    unit = "integers" if integer else "numbers"
    left = "(" if low_open else "["
    allowed = f"(lo, hi) {unit} with lo <= hi inside {left}{low:g}, {high:g}]"
    if not isinstance(bounds, tuple | list) or len(bounds) != 2:
        raise ConfigurationError(name, bounds, allowed)
    lo, hi = bounds
    for v in (lo, hi):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ConfigurationError(name, bounds, allowed)
        if integer and not float(v).is_integer():
            raise ConfigurationError(name, bounds, allowed)
    if lo > hi:
        raise ConfigurationError(name, bounds, f"{allowed} (the bounds are inverted)")
    if (lo <= low if low_open else lo < low) or hi > high:
        raise ConfigurationError(name, bounds, allowed)
    return float(lo), float(hi)


def simple_first(simple: T, strategy: st.SearchStrategy[T]) -> st.SearchStrategy[T]:
    """``strategy``, shrinking towards ``simple`` (one_of shrinks towards its first branch)."""
    return st.one_of(st.just(simple), strategy)


def fidelities(levels: Sequence[str] = FIDELITIES) -> st.SearchStrategy[str]:
    """A fidelity level among ``levels``; shrinks towards the first (the cheapest)."""
    levels = tuple(levels)
    bad = [level for level in levels if level not in FIDELITIES]
    if not levels or bad:
        raise ConfigurationError("levels", levels, f"one or more of {FIDELITIES}")
    return st.sampled_from(levels)


def world_configs(
    *,
    timestep: Range = (0.0005, 0.01),
    integrators: Sequence[str] | None = None,
    solvers: Sequence[str] | None = None,
    iterations: tuple[int, int] = (1, 200),
    base: WorldConfig | None = None,
) -> st.SearchStrategy[WorldConfig]:
    """MuJoCo world configurations (the paper's ODE iterations and step size, and more).

    Shrinks towards ``base`` (default: ``WorldConfig()``): its timestep, integrator, solver
    and iterations when they lie in the ranges, else towards the largest timestep, the first
    integrator and solver listed and the fewest iterations (the cheapest to simulate).
    """
    from ..physics import INTEGRATORS, SOLVERS, WorldConfig
    from ..physics.config import MAX_ITERATIONS, MAX_TIMESTEP, MIN_TIMESTEP

    base = base if base is not None else WorldConfig()
    lo, hi = check_range("timestep", timestep, low=MIN_TIMESTEP, high=MAX_TIMESTEP)
    if hi > base.period:
        raise ConfigurationError(
            "timestep", timestep, f"timesteps <= the world's period ({base.period:g} s)"
        )
    it_lo, it_hi = check_range("iterations", iterations, low=1, high=MAX_ITERATIONS, integer=True)
    integrator_choices = _choices("integrators", integrators, INTEGRATORS, base.integrator)
    solver_choices = _choices("solvers", solvers, SOLVERS, base.solver)

    # A larger step is cheaper: draw the fraction of the range below the largest step.
    step = st.floats(0.0, 1.0).map(lambda u: hi - u * (hi - lo))
    if lo <= base.timestep <= hi:
        step = simple_first(base.timestep, step)
    iters = st.integers(int(it_lo), int(it_hi))
    if it_lo <= base.iterations <= it_hi:
        iters = simple_first(base.iterations, iters)

    def build(ts: float, integrator: Any, solver: Any, n: int) -> WorldConfig:
        import dataclasses

        # integrator and solver were checked against the allowed names above.
        return dataclasses.replace(
            base, timestep=ts, integrator=integrator, solver=solver, iterations=n
        )

    return st.builds(
        build,
        step,
        st.sampled_from(integrator_choices),
        st.sampled_from(solver_choices),
        iters,
    )


def _choices(
    name: str, given: Sequence[str] | None, allowed: Sequence[str], preferred: str
) -> list[str]:
    values = list(allowed if given is None else given)
    bad = [v for v in values if v not in allowed]
    if not values or bad or isinstance(given, str):
        raise ConfigurationError(name, given, f"a non-empty list drawn from {tuple(allowed)}")
    if preferred in values:  # sampled_from shrinks towards the first element
        values.remove(preferred)
        values.insert(0, preferred)
    return values


def obstacles(
    *,
    count: tuple[int, int] = (0, 4),
    north: Range = (-100.0, 100.0),
    east: Range = (-100.0, 100.0),
    size: Range = (1.0, 20.0),
    height: Range = (2.0, 40.0),
    kinds: Sequence[str] = ("box", "cylinder"),
    home: tuple[float, float, float] | None = None,
) -> st.SearchStrategy[tuple[Obstacle, ...]]:
    """Obstacles for ``WorldConfig.obstacles``: ``count`` of them, none overlapping another
    or standing near home (valid by construction), their centres within ``north``/``east``
    (m), their footprints' sides (a box's length and width, a cylinder's diameter) within
    ``size`` and their heights within ``height`` (m). Shrinks towards fewer, smaller obstacles.
    """
    from ..physics import DEFAULT_HOME, Box, Cylinder
    from ..physics.obstacles import check_obstacles

    fewest, most = check_range("count", count, low=0, high=50, integer=True)
    n_lo, n_hi = check_range("north", north, low=-1e5, high=1e5)
    e_lo, e_hi = check_range("east", east, low=-1e5, high=1e5)
    s_lo, s_hi = check_range("size", size, low=0.0, high=1e3, low_open=True)
    h_lo, h_hi = check_range("height", height, low=0.0, high=1e3, low_open=True)
    shapes = _choices("kinds", kinds, ("box", "cylinder"), "box")
    where = home if home is not None else DEFAULT_HOME

    def one(draw: st.DrawFn) -> Obstacle:
        kind = draw(st.sampled_from(shapes))
        n, e = draw(st.floats(n_lo, n_hi)), draw(st.floats(e_lo, e_hi))
        tall = draw(st.floats(h_lo, h_hi))
        if kind == "cylinder":
            side = draw(st.floats(s_lo, s_hi))
            return Cylinder(radius=side / 2, height=tall, north=n, east=e)
        return Box(
            length=draw(st.floats(s_lo, s_hi)),
            width=draw(st.floats(s_lo, s_hi)),
            height=tall,
            yaw=draw(st.floats(0.0, 180.0)),
            north=n,
            east=e,
        )

    @st.composite
    def draw_obstacles(draw: st.DrawFn) -> tuple[Obstacle, ...]:
        wanted = draw(st.integers(int(fewest), int(most)))
        chosen: list[Obstacle] = []
        for _ in range(wanted * 10):  # a candidate that overlaps is drawn again
            if len(chosen) == wanted:
                break
            candidate = one(draw)
            try:
                check_obstacles([*chosen, candidate], where)
            except ConfigurationError:
                continue
            chosen.append(candidate)
        hypothesis.assume(len(chosen) >= fewest)  # the bounds were too crowded
        return tuple(chosen)

    return draw_obstacles()


def winds(
    *,
    speed: Range = (0.0, 15.0),
    turbulence: Range = (0.0, 15.4),
    gusts: tuple[int, int] = (0, 2),
    gust_speed: Range = (0.0, 10.0),
    gust_start: Range = (0.0, 120.0),
    gust_duration: Range = (0.5, 10.0),
) -> st.SearchStrategy[Wind]:
    """A [`Wind`][multicosim.physics.Wind]: steady ``speed`` (m/s) from any direction, Dryden
    ``turbulence`` (W20, m/s; 15.4 is MIL-F-8785C's moderate) and ``gusts`` 1-cosine gusts.
    Shrinks towards still air."""
    from ..physics import Gust, Wind
    from ..physics.wind import MAX_WIND

    v_lo, v_hi = check_range("speed", speed, low=0.0, high=MAX_WIND)
    t_lo, t_hi = check_range("turbulence", turbulence, low=0.0, high=MAX_WIND)
    g_lo, g_hi = check_range("gusts", gusts, low=0, high=20, integer=True)
    gv_lo, gv_hi = check_range("gust_speed", gust_speed, low=0.0, high=MAX_WIND)
    gs_lo, gs_hi = check_range("gust_start", gust_start, low=0.0, high=1e6)
    gd_lo, gd_hi = check_range("gust_duration", gust_duration, low=0.0, high=1e4, low_open=True)
    direction = st.floats(0.0, 360.0, exclude_max=True)
    gust = st.builds(
        Gust,
        start=st.floats(gs_lo, gs_hi),
        duration=st.floats(gd_lo, gd_hi),
        speed=st.floats(gv_lo, gv_hi),
        direction=direction,
    )
    return st.builds(
        Wind,
        speed=simple_first(v_lo, st.floats(v_lo, v_hi)),
        direction=direction,
        gusts=st.lists(gust, min_size=int(g_lo), max_size=int(g_hi)).map(tuple),
        turbulence=simple_first(t_lo, st.floats(t_lo, t_hi)),
    )


def noise_levels(high: float, *, low: float = 0.0) -> st.SearchStrategy[float]:
    """A noise standard deviation in [low, high]; shrinks towards ``low`` (no noise)."""
    lo, hi = check_range("noise", (low, high), low=0.0, high=math.inf)
    return simple_first(lo, st.floats(lo, hi))


def target_robustness(value: float | Evaluation, *, label: str = "robustness") -> float:
    """Guide Hypothesis towards violations: ``hypothesis.target(-robustness)``.

    Returns the robustness. Outside a Hypothesis test it only returns it, so the same
    property can be called from plain code. Infinite values are clipped (target needs finite).
    """
    robustness = float(value if isinstance(value, int | float) else value.robustness)
    if math.isnan(robustness):
        raise ConfigurationError("robustness", robustness, "a number (not NaN)")
    if hypothesis.currently_in_test_context():
        hypothesis.target(-max(-1e300, min(1e300, robustness)), label=label)
    return robustness


# -- a fresh simulation per example ---------------------------------------------------------


class FreshSimulations:
    """Starts a new simulation for every Hypothesis example, stopped when the example ends.

    The object behind the ``mcs_fresh_simulation`` fixture. It holds no per-test state, so a
    session-scoped fixture can provide it (Hypothesis refuses function-scoped fixtures in
    ``@given`` tests because they are not reset between examples). Calling it with a
    simulator factory gives a context manager:

    ```python
    with mcs_fresh_simulation(rover.Rover, world=config) as simulation: ...
    ```

    The factory is called with ``fidelity`` and ``seed`` (when it accepts them) and the extra
    keyword arguments; what it returns is started (if it has ``start``) and stopped at the
    end of the block. Fidelity and seed come from the arguments given here, else from the
    running test (set by the pytest plugin), else ``"low"`` and 0. When the test records a
    trace, the simulation is recorded and the previous example's recording is dropped, so a
    failing test keeps the trace of its final, minimal example.
    """

    def __init__(self, *, fidelity: str | None = None, seed: int | None = None) -> None:
        if fidelity is not None:
            check_fidelity(fidelity)
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
            raise ConfigurationError("seed", seed, "a non-negative integer")
        self.fidelity = fidelity
        self.seed = seed
        self.started = 0
        self.last: Any = None

    def __repr__(self) -> str:
        # Hypothesis prints the fixture in the failing example: keep it short and stable.
        args = [f"{k}={v!r}" for k, v in (("fidelity", self.fidelity), ("seed", self.seed)) if v]
        return f"FreshSimulations({', '.join(args)})"

    def settings(self) -> tuple[str, int]:
        """The fidelity and seed the next simulation gets."""
        from .. import trace

        current = trace.active()
        meta = current.metadata if current is not None else {}
        fidelity = self.fidelity or str(meta.get("fidelity") or "low")
        seed = self.seed if self.seed is not None else int(str(meta.get("seed") or 0))
        return fidelity, seed

    @contextlib.contextmanager
    def __call__(self, factory: Callable[..., Any], /, **kwargs: Any) -> Iterator[Any]:
        """Build, start, yield and stop one simulation (see the class docstring)."""
        __tracebackhide__ = True  # a failure in the block is the test's, not this frame's
        from .. import trace

        fidelity, seed = self.settings()
        offered = {"fidelity": fidelity, "seed": seed}
        accepted = _accepted(factory, offered)
        built = factory(**accepted, **kwargs)
        current = trace.active()
        if current is not None:
            current.begin_example()
        simulation = built.start() if callable(getattr(built, "start", None)) else built
        self.started += 1
        self.last = simulation
        try:
            if current is not None:
                current.attach(simulation)
            yield simulation
        finally:
            simulation.stop()


def _accepted(factory: Callable[..., Any], offered: dict[str, Any]) -> dict[str, Any]:
    try:
        params = inspect.signature(factory).parameters
    except (TypeError, ValueError):
        return {}
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return dict(offered)
    return {k: v for k, v in offered.items() if k in params}
