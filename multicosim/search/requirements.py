"""Signal temporal logic requirements over trajectories, with robustness (via rtamt).

```python
import multicosim.search.requirements as req

altitude = req.Requirement("always (alt >= 0)")
evaluation = altitude.evaluate({"alt": [1.0, -0.5, 2.0]}, times=[0.0, 1.0, 2.0])
evaluation.robustness   # -0.5: violated by 0.5 m
evaluation.worst_time   # 1.0
altitude.check(trajectory)  # raises RequirementViolation (an AssertionError) if violated
```

Semantics: dense time by default (rtamt's ``StlDenseTimeSpecification``, as the paper's
``parse_dense``): samples may be irregular, time bounds are seconds, and a signal holds its
value between samples. ``semantics="discrete"`` uses rtamt's discrete-time monitor, which needs
uniformly sampled trajectories (time bounds are still in seconds). The robustness is the
formula's value at the trajectory's first instant; it is negative exactly when the requirement
is violated (0 is the boundary and counts as satisfied).

A trajectory is a mapping of signal name to values plus ``times`` (or a ``"time"`` entry), or
a sequence of msgspec Structs (or dataclasses) with a ``time`` field, whose numeric fields
become signals (a rover ``Trajectory`` is one).
"""

from __future__ import annotations

import dataclasses
import importlib
import warnings
from collections.abc import Callable, Mapping, Sequence
from types import ModuleType
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..core.deps import require
from ..core.errors import (
    ConfigurationError,
    FormulaError,
    MulticosimError,
    tidy_expected,
    translate,
)
from ..core.signals import FloatArray, Signals, signals_of
from ..trace import note_evaluation

__all__ = [
    "Evaluation",
    "FormulaError",
    "Requirement",
    "RequirementViolation",
    "Semantics",
    "Signals",
    "add_observer",
    "assert_satisfied",
    "signals_of",
]

Semantics = Literal["dense", "discrete"]
SEMANTICS: tuple[Semantics, ...] = ("dense", "discrete")
Derived = Callable[[Mapping[str, FloatArray]], ArrayLike]

# Relative tolerance of the sampling period for discrete-time evaluation: simulated times
# built by adding a float period drift by far less than this.
_PERIOD_TOLERANCE = 0.01


@dataclasses.dataclass(frozen=True)
class Evaluation:
    """The outcome of evaluating a requirement on a trajectory.

    ``robustness`` < 0 means violated (by that margin); ``worst_time`` is the instant whose
    signal values decide the robustness (for ``always``: where the margin is smallest) and
    ``values`` are the formula's signals there; ``predicate`` is the atomic proposition that
    decided it.
    """

    formula: str
    robustness: float
    worst_time: float
    values: Mapping[str, float]
    predicate: str = ""
    # The deciding predicate's margin over time, ((time, margin), ...): for plots and traces.
    series: tuple[tuple[float, float], ...] = dataclasses.field(
        default=(), repr=False, compare=False
    )

    @property
    def satisfied(self) -> bool:
        """Whether the requirement holds (robustness >= 0)."""
        return self.robustness >= 0.0

    @property
    def first_violation(self) -> float | None:
        """The first instant the deciding predicate's margin is negative (None if it holds).

        For ``always`` this is where the trajectory first leaves the allowed region; the
        worst time is where it is furthest out.
        """
        if self.satisfied:
            return None
        first = next((t for t, margin in self.series if margin < 0), None)
        return self.worst_time if first is None else first

    def explain(self) -> str:
        """A one-paragraph account: verdict, robustness, worst time and values there.

        A violation names both instants: where it was first violated and where the
        robustness is at its worst (they differ when a trajectory stays out for a while).
        """
        values = ", ".join(f"{k}={v:.6g}" for k, v in self.values.items())
        first = self.first_violation
        if first is None:
            verdict = "holds: robustness"
        else:
            verdict = f"is violated: first violated at t={first:.6g} s; worst robustness"
        text = (
            f"requirement {self.formula!r} {verdict} {self.robustness:.6g} "
            f"at t={self.worst_time:.6g} s ({values})"
        )
        if self.predicate:
            text += f"; decided by {self.predicate}"
        return text

    def __str__(self) -> str:
        return self.explain()


@dataclasses.dataclass(frozen=True)
class _Atom:
    """An atomic proposition of a formula, monitored alone to find the deciding instant."""

    text: str
    variables: tuple[str, ...]


class RequirementViolation(MulticosimError, AssertionError):
    """Raised by ``Requirement.check``: the requirement does not hold on a trajectory.

    An ``AssertionError`` too, so that pytest reports it as a failed assertion.
    """

    def __init__(self, evaluation: Evaluation) -> None:
        self.evaluation = evaluation
        super().__init__(evaluation.explain())


# Shown as ``multicosim.RequirementViolation``, as every error is (see multicosim.core.errors).
RequirementViolation.__module__ = "multicosim"


class Requirement:
    """An STL requirement, e.g. ``Requirement("always (alt >= 0)")``; parsed on construction.

    ``derived`` adds signals computed from the trajectory's columns, e.g.
    ``{"alt": lambda s: s["z"]}``; ``semantics`` is ``"dense"`` (default) or ``"discrete"``.
    """

    def __init__(
        self,
        formula: str,
        *,
        semantics: Semantics = "dense",
        derived: Mapping[str, Derived] | None = None,
        name: str | None = None,
    ) -> None:
        if not isinstance(formula, str) or not formula.strip():
            raise ConfigurationError("formula", formula, "a non-empty STL formula")
        if semantics not in SEMANTICS:
            raise ConfigurationError("semantics", semantics, f"one of {SEMANTICS}")
        self._rtamt = load_rtamt()
        self.formula = formula.strip()
        self.semantics: Semantics = semantics
        self.derived: dict[str, Derived] = dict(derived or {})
        self.name = name or self.formula
        self.variables = _identifiers(self.formula)
        # Parsed monitors by (formula text, sampling period); rtamt parsing costs milliseconds.
        self._specs: dict[tuple[str, float | None], Any] = {}
        spec = self._spec(self.formula, self.variables, None)
        self._atoms = [_Atom(text, vs) for text, vs in _atoms(spec)]

    def __repr__(self) -> str:
        return f"Requirement({self.formula!r}, semantics={self.semantics!r})"

    # -- parsing --------------------------------------------------------------------------

    def _spec(self, formula: str, variables: Sequence[str], period: float | None) -> Any:
        key = (formula, period)
        spec = self._specs.get(key)
        if spec is None:
            spec = self._specs[key] = self._parse(formula, variables, period)
        return spec

    def _parse(self, formula: str, variables: Sequence[str], period: float | None) -> Any:
        rtamt = self._rtamt
        if self.semantics == "dense":
            spec = rtamt.StlDenseTimeSpecification()
        else:
            spec = rtamt.StlDiscreteTimeSpecification()
            spec.set_sampling_period(period or 1.0, "s", _PERIOD_TOLERANCE)
        for v in variables:
            spec.declare_var(v, "float")
        spec.spec = formula
        try:
            spec.parse()
        except Exception as exc:  # rtamt raises bare KeyErrors etc. for malformed input
            raise translate(exc, formula=formula) or exc from None
        return spec

    # -- evaluation -----------------------------------------------------------------------

    def signals(self, trajectory: object, *, times: ArrayLike | None = None) -> Signals:
        """The trajectory's columns plus the derived signals, checked against the formula."""
        base = signals_of(trajectory, times=times)
        columns = dict(base.columns)
        for name, fn in self.derived.items():
            values = np.asarray(fn(base.columns), dtype=np.float64)
            if values.shape != base.times.shape:
                raise ConfigurationError(
                    f"derived[{name!r}]", f"{values.size} values", f"{len(base)} values"
                )
            columns[name] = values
        missing = [v for v in self.variables if v not in columns]
        if missing:
            raise ConfigurationError(
                "signal",
                missing[0],
                f"one of the trajectory's signals {sorted(columns)} "
                f"(the formula {self.formula!r} uses {', '.join(map(repr, missing))})",
            )
        for v in self.variables:
            bad = ~np.isfinite(columns[v])
            if bad.any():
                i = int(np.argmax(bad))
                raise ConfigurationError(
                    f"trajectory[{v!r}]",
                    f"{columns[v][i]} at t={base.times[i]:g} s",
                    "finite values",
                )
        return Signals(base.times, columns)

    def robustness(self, trajectory: object, *, times: ArrayLike | None = None) -> float:
        """The robustness alone (cheaper than
        [`evaluate`][multicosim.search.requirements.Requirement.evaluate])."""
        return self._robustness(self.signals(trajectory, times=times))

    def evaluate(self, trajectory: object, *, times: ArrayLike | None = None) -> Evaluation:
        """Robustness, the instant that decides it and the signal values there."""
        signals = self.signals(trajectory, times=times)
        rho = self._robustness(signals)
        worst, atom, series = self._worst(signals, rho)
        evaluation = Evaluation(
            formula=self.formula,
            robustness=rho,
            worst_time=worst,
            values=signals.at(worst, self.variables),
            predicate=atom.text if atom is not None else "",
            series=series,
        )
        _notify(self, signals, evaluation)
        return evaluation

    def check(self, trajectory: object, *, times: ArrayLike | None = None) -> Evaluation:
        """Evaluate; raise RequirementViolation (an AssertionError) when violated."""
        __tracebackhide__ = True  # a failing test's report shows the verdict, not this frame
        evaluation = self.evaluate(trajectory, times=times)
        if not evaluation.satisfied:
            raise RequirementViolation(evaluation)
        return evaluation

    def _robustness(self, signals: Signals) -> float:
        return float(self._series(self.formula, self.variables, signals)[0][1])

    def _series(self, formula: str, variables: Sequence[str], signals: Signals) -> list[Any]:
        """The robustness signal of ``formula``: ``[[time, value], ...]``."""
        t = signals.times.tolist()
        if self.semantics == "dense":
            spec = self._spec(formula, variables, None)
            data = [
                [v, [[a, b] for a, b in zip(t, signals.columns[v].tolist(), strict=True)]]
                for v in variables
            ]
            result: list[Any] = spec.evaluate(*data)
            return result
        spec = self._spec(formula, variables, _period(signals))
        dataset: dict[str, list[float]] = {"time": t}
        for v in variables:
            dataset[v] = signals.columns[v].tolist()
        result = spec.evaluate(dataset)
        return result

    def _worst(
        self, signals: Signals, rho: float
    ) -> tuple[float, _Atom | None, tuple[tuple[float, float], ...]]:
        """The earliest sample where an atom's margin equals the robustness (up to sign).

        Returns that time, the atom and the atom's margin over time.
        """
        best: tuple[int, float, float, _Atom, list[Any]] | None = None
        tolerance = 1e-9 * max(1.0, abs(rho))
        for atom in self._atoms:
            series = self._series(atom.text, atom.variables, signals)
            times = np.array([p[0] for p in series], dtype=np.float64)
            margin = np.array([p[1] for p in series], dtype=np.float64)
            # A negated atom decides with the opposite sign: rank an exact match first.
            for rank, target in ((0, rho), (1, -rho)):
                error = np.abs(margin - target)
                i = int(np.argmin(error))
                if error[i] <= tolerance and (
                    best is None or (rank, float(times[i])) < (best[0], best[1])
                ):
                    best = (rank, float(times[i]), float(error[i]), atom, series)
        if best is not None:
            return best[1], best[3], _at_samples(best[4], signals.times)
        # No sample matches (a value interpolated by a time bound): report the start.
        return float(signals.times[0]), None, ()


def _at_samples(series: list[Any], times: FloatArray) -> tuple[tuple[float, float], ...]:
    """A robustness signal at every sample time (rtamt's dense output keeps change points)."""
    t = np.array([p[0] for p in series], dtype=np.float64)
    v = np.array([p[1] for p in series], dtype=np.float64)
    index = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 1)
    return tuple(zip(times.tolist(), v[index].tolist(), strict=True))


def _period(signals: Signals) -> float:
    """The sampling period of a uniformly sampled trajectory (discrete time needs one)."""
    t = signals.times
    if len(t) < 2:
        raise ConfigurationError(
            "trajectory", f"{len(t)} sample", "at least two samples for semantics='discrete'"
        )
    steps = np.diff(t)
    period = float(np.median(steps))
    if np.max(np.abs(steps - period)) > _PERIOD_TOLERANCE * period:
        raise ConfigurationError(
            "times",
            f"periods from {steps.min():g} to {steps.max():g} s",
            "uniform sampling for semantics='discrete' (use 'dense' for irregular samples)",
        )
    # Rounded so that trajectories of the same rate share one parsed monitor.
    return float(f"{period:.9g}")


def assert_satisfied(
    requirement: Requirement | str, trajectory: object, *, times: ArrayLike | None = None
) -> Evaluation:
    """Fail (RequirementViolation) with robustness, worst time and values if violated."""
    __tracebackhide__ = True
    if isinstance(requirement, str):
        requirement = Requirement(requirement)
    return requirement.check(trajectory, times=times)


# -- helpers around rtamt --------------------------------------------------------------------


def load_rtamt() -> ModuleType:
    """Import rtamt (DependencyMissingError naming the ``stl`` extra if it is missing)."""
    with warnings.catch_warnings():
        # rtamt's ANTLR runtime imports the deprecated typing.io: not ours to fix, and
        # fatal under pytest's filterwarnings=error.
        warnings.simplefilter("ignore", DeprecationWarning)
        return require("rtamt", "stl")


def _identifiers(formula: str) -> tuple[str, ...]:
    """Check that ``formula`` is one STL formula; return the signal names it uses, in order.

    Runs rtamt's own lexer and parser with an error listener that keeps the position (rtamt
    alone reports lexer errors on stderr, and silently ignores a second formula).
    """
    load_rtamt()
    # Imported by name: the ANTLR runtime (an rtamt dependency) ships no type information.
    antlr4 = importlib.import_module("antlr4")
    LtlLexer = importlib.import_module("rtamt.antlr.parser.stl.LtlLexer").LtlLexer
    StlParser = importlib.import_module("rtamt.antlr.parser.stl.StlParser").StlParser

    class _Stop(Exception):
        pass

    class _Raise:
        """An ANTLR error listener that stops at the first error, keeping its position."""

        def syntaxError(
            self, recognizer: object, symbol: object, line: int, column: int, msg: str, e: object
        ) -> None:
            raise _Stop(line, column, msg)

        def reportAmbiguity(self, *args: object) -> None:
            pass

        def reportAttemptingFullContext(self, *args: object) -> None:
            pass

        def reportContextSensitivity(self, *args: object) -> None:
            pass

    lexer = LtlLexer(antlr4.InputStream(formula))
    lexer.removeErrorListeners()  # the default listener prints to stderr
    lexer.addErrorListener(_Raise())
    stream = antlr4.CommonTokenStream(lexer)
    parser = StlParser(stream)
    parser.removeErrorListeners()
    parser.addErrorListener(_Raise())
    try:
        tree = parser.specification_file()
    except _Stop as stop:
        line, column, msg = stop.args
        raise FormulaError(formula, line, column, tidy_expected(msg)) from None
    statements = list(tree.specification().getChildren())
    if len(statements) != 1 or type(statements[0]).__name__ != "AssertionContext":
        extra = statements[1] if len(statements) > 1 else statements[0]
        token = extra.start
        raise FormulaError(
            formula,
            token.line,
            token.column,
            f"a second formula starts at {token.text!r}: give exactly one formula "
            "(is an operator or a parenthesis missing?)",
        )
    names = [
        t.text
        for t in stream.tokens
        if t.type == LtlLexer.Identifier and t.channel == antlr4.Token.DEFAULT_CHANNEL
    ]
    return tuple(dict.fromkeys(names))


def _atoms(spec: Any) -> list[tuple[str, tuple[str, ...]]]:
    """Atomic propositions (predicates, bare variables) of a parsed spec, as formula text."""
    found: dict[str, tuple[str, ...]] = {}

    def variables(node: Any) -> list[str]:
        if type(node).__name__ == "Variable":
            return [str(node.name)]
        return [v for child in node.children for v in variables(child)]

    def walk(node: Any) -> None:
        kind = type(node).__name__
        if kind in ("Predicate", "Variable"):
            found.setdefault(node.name, tuple(dict.fromkeys(variables(node))))
            return
        for child in node.children:
            walk(child)

    for top in spec.ast.specs:
        walk(top)
    return list(found.items())


# -- observers of evaluations (multicosim.trace notes them in the active test's trace) ---------

Observer = Callable[["Requirement", Signals, Evaluation], None]
_observers: list[Observer] = []


def add_observer(observer: Observer) -> Callable[[], None]:
    """Call ``observer(requirement, signals, evaluation)`` after every evaluation.

    Returns the function that removes it again. ``multicosim.trace`` adds one when it is
    imported, so that a test's trace shows the requirements evaluated in it.
    """
    _observers.append(observer)

    def remove() -> None:
        if observer in _observers:
            _observers.remove(observer)

    return remove


def _notify(requirement: Requirement, signals: Signals, evaluation: Evaluation) -> None:
    for observer in tuple(_observers):
        observer(requirement, signals, evaluation)


# Every requirement evaluated while a test records is noted in that test's trace.
add_observer(note_evaluation)
