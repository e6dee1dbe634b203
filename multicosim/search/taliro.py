"""psy-taliro 3.x integration: each sample is one simulation at a chosen fidelity.

The paper's appendix, adapted to psy-taliro 3.x (``staliro.model``, ``staliro.TestOptions``,
``staliro.test``) and to the MuJoCo world (``WorldConfig(iterations=..., timestep=...)`` in
place of ``Gazebo(backend=ODE(iterations=...), step_size=...)``):

```python
import multicosim.search.taliro as mtaliro

def simulate(static, fidelity, seed):    # static inputs -> trajectory
    world = WorldConfig(iterations=round(static["iters"]), timestep=static["step_size"])
    with rover.Rover(fidelity=fidelity, seed=seed, world=world).start() as sim:
        return sim.controller.send(rover.Mission(speed=static["speed"]))

result = mtaliro.falsify(
    simulate,
    "always (z > 0.0)",
    static_inputs={"iters": (1, 100), "step_size": (0.001, 0.01), "speed": (1.0, 10.0)},
    iterations=50,
    fidelity="medium",
    trace_dir="traces",
)
result.falsified, result.sample, result.robustness, result.traces
```

[`model`][multicosim.search.taliro.model] and
[`specification`][multicosim.search.taliro.specification] give the psy-taliro objects themselves,
for use with ``staliro.test`` and any psy-taliro optimizer. The simulate function has multicosim's
one callback shape, ``simulate(sample, fidelity, seed)`` (as for campaigns and
[`multicosim.search.falsify.falsify`][multicosim.search.falsify.falsify], which also drives
psy-taliro's optimizers over spaces with integer and choice dimensions and across fidelity levels).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..core.deps import require
from ..core.errors import ConfigurationError
from ..core.fidelity import check_fidelity
from .campaign import Simulate, check_simulate
from .requirements import Evaluation, Requirement, Signals, load_rtamt

load_rtamt()  # psy-taliro imports rtamt; this keeps its import warnings quiet
with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    staliro = require("staliro", "taliro")
    staliro_optimizers = require("staliro.optimizers", "taliro")

__all__ = [
    "Simulate",
    "TaliroResult",
    "falsify",
    "model",
    "specification",
]


@dataclasses.dataclass(frozen=True)
class _Annotation:
    """What the model hands on with each trace: the columns as simulated."""

    signals: Signals
    fidelity: str


def model(
    simulate: Simulate,
    *,
    fidelity: str = "low",
    seed: int = 0,
    signals: tuple[str, ...] | None = None,
) -> Any:
    """A psy-taliro model: each sample runs ``simulate(sample.static, fidelity, seed)``.

    The returned trajectory becomes a ``staliro.Trace`` of ``{signal: value}`` states (all
    numeric signals, or only ``signals``), usable with ``staliro.specifications.rtamt``.
    """
    check_simulate(simulate)
    check_fidelity(fidelity)
    from .requirements import signals_of

    def run(inputs: Any) -> Any:
        # psy-taliro hands NumPy scalars; messages want plain floats.
        static = {str(k): float(v) for k, v in inputs.static.items()}
        columns = signals_of(simulate(static, fidelity, seed))
        names = list(signals) if signals is not None else list(columns.columns)
        missing = [n for n in names if n not in columns.columns]
        if missing:
            raise ConfigurationError(
                "signals", missing, f"signals of the trajectory ({sorted(columns.columns)})"
            )
        states = [{n: float(columns.columns[n][i]) for n in names} for i in range(len(columns))]
        trace = staliro.Trace(times=columns.times.tolist(), states=states)
        return staliro.Result(trace, _Annotation(columns, fidelity))

    return staliro.model(run)


def specification(requirement: Requirement | str) -> Any:
    """A psy-taliro specification evaluating ``requirement`` with multicosim's monitor.

    Its annotation is the [`Evaluation`][multicosim.search.requirements.Evaluation] (worst time,
    values).
    """
    req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)

    def evaluate(trace: Any) -> Any:
        times = list(trace.times)
        states = list(trace.states)
        columns = {name: [s[name] for s in states] for name in (states[0] if states else {})}
        evaluation = req.evaluate(columns, times=times)
        return staliro.Result(evaluation.robustness, evaluation)

    return staliro.specification(evaluate)


@dataclasses.dataclass(frozen=True)
class TaliroResult:
    """The outcome of a psy-taliro search.

    ``sample`` and ``robustness`` are the lowest-robustness sample (the falsifying one when
    ``falsified``); ``evaluation`` explains it; ``traces`` are its saved trace and plot;
    ``runs`` is psy-taliro's own result.
    """

    falsified: bool
    sample: Mapping[str, float]
    robustness: float
    evaluation: Evaluation
    evaluations: int
    traces: tuple[Path, ...]
    runs: Any


def falsify(
    simulate: Simulate,
    requirement: Requirement | str,
    *,
    static_inputs: Mapping[str, tuple[float, float]],
    iterations: int = 50,
    fidelity: str = "low",
    seed: int = 0,
    optimizer: Any = None,
    trace_dir: str | Path | None = None,
    executor: Any = None,
    ray_address: str | None = None,
) -> TaliroResult:
    """Search ``static_inputs`` with psy-taliro (default: UniformRandom) at ``fidelity``.

    Stops at the first falsifying sample (robustness < 0). Every sample runs
    ``simulate(sample, fidelity, seed)``; ``seed`` (>= 0) is passed to psy-taliro as
    ``seed + 1`` (it needs seeds > 0). With ``trace_dir``, the lowest
    robustness sample is simulated once more while recording, and its trace and plot are
    saved there.

    With ``executor`` (``"process"``, ``"ray"``, or a
    [`multicosim.search.campaign`][multicosim.search.campaign] executor) or ``ray_address``, the
    optimizer's batches run through that executor, each sample with the seed of its index
    ([`multicosim.search.campaign.sample_seed`][multicosim.search.campaign.sample_seed]); the
    default optimizer then draws the whole budget as one batch (no early stop). ``simulate`` must be
    picklable.
    """
    check_simulate(simulate)
    if not static_inputs:
        raise ConfigurationError("static_inputs", static_inputs, "at least one input range")
    for name, bounds in static_inputs.items():
        if (
            not isinstance(bounds, tuple | list)
            or len(bounds) != 2
            or not all(isinstance(b, int | float) and not isinstance(b, bool) for b in bounds)
            or not bounds[0] < bounds[1]
        ):
            raise ConfigurationError(f"static_inputs[{name!r}]", bounds, "(low, high), low < high")
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ConfigurationError("iterations", iterations, "a positive number of samples")
    req = requirement if isinstance(requirement, Requirement) else Requirement(requirement)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigurationError("seed", seed, "a non-negative integer")
    # psy-taliro wants seeds > 0; ours start at 0 like every multicosim seed.
    options = staliro.TestOptions(
        static_inputs=dict(static_inputs), iterations=iterations, seed=seed + 1
    )
    if executor is None and ray_address is None:
        opt = optimizer if optimizer is not None else staliro_optimizers.UniformRandom(min_cost=0.0)
        runs = staliro.test(
            model(simulate, fidelity=fidelity, seed=seed), specification(req), opt, options
        )
    else:
        opt = optimizer if optimizer is not None else staliro_optimizers.UniformRandom()
        runs = _run_on(executor, ray_address, simulate, req, opt, options, fidelity, seed)
    evaluations = [e for run in runs for e in run.evaluations]
    if not evaluations:
        raise ConfigurationError("iterations", iterations, "a budget that evaluates a sample")
    best = min(evaluations, key=lambda e: e.cost)
    sample = {str(k): float(v) for k, v in best.inputs.static.items()}
    evaluation: Evaluation = best.extra.spec
    traces: tuple[Path, ...] = ()
    if trace_dir is not None:
        traces = _record(simulate, req, sample, fidelity, seed, Path(trace_dir))
    return TaliroResult(
        falsified=best.cost < 0,
        sample=sample,
        robustness=float(best.cost),
        evaluation=evaluation,
        evaluations=len(evaluations),
        traces=traces,
        runs=runs,
    )


@dataclasses.dataclass(frozen=True)
class _Extra:
    """What psy-taliro keeps with an evaluation (``.spec``, as its own cost function does)."""

    model: Any
    spec: Evaluation


class _CampaignObjective:
    """A psy-taliro objective whose batches are campaign batches."""

    def __init__(self, campaign: Any, options: Any) -> None:
        self.campaign = campaign
        self.options = options
        self.evaluations: list[Any] = []

    def eval_sample(self, sample: Any) -> float:
        return self.eval_samples([sample])[0]

    def eval_samples(self, samples: Any) -> list[float]:
        from ..core.errors import MulticosimError

        inputs = [self.options.parse_sample(s) for s in samples]
        static = [{str(k): float(v) for k, v in i.static.items()} for i in inputs]
        results = self.campaign.evaluate(static)
        for i, result in zip(inputs, results, strict=True):
            if result.evaluation is None:
                raise MulticosimError(f"sample {result.index} {result.status}: {result.error}")
            self.evaluations.append(
                staliro.Evaluation(i, result.robustness, _Extra(None, result.evaluation))
            )
        return [float(r.robustness) for r in results]


def _run_on(
    executor: Any,
    ray_address: str | None,
    simulate: Simulate,
    requirement: Requirement,
    optimizer: Any,
    options: Any,
    fidelity: str,
    seed: int,
) -> list[Any]:
    import numpy as np

    from .campaign import Campaign

    with Campaign(
        simulate,
        requirement,
        fidelity=fidelity,
        seed=seed,
        executor=executor,
        ray_address=ray_address,
        progress=False,
    ) as campaign:
        objective = _CampaignObjective(campaign, options)
        # The optimizer's seed as staliro.test derives it: the same samples either way.
        run_seed = int(np.random.default_rng(options.seed).integers(0, 2**32 - 1, dtype=int))
        params = staliro_optimizers.Optimizer.Params(
            seed=run_seed, budget=options.iterations, input_bounds=options.intervals()
        )
        outcome = optimizer.optimize(objective, params)
    return [staliro.Run(outcome, objective.evaluations)]


def _record(
    simulate: Simulate,
    requirement: Requirement,
    sample: Mapping[str, float],
    fidelity: str,
    seed: int,
    directory: Path,
) -> tuple[Path, ...]:
    """Simulate ``sample`` again while recording; save trace and plot in ``directory``."""
    from .. import trace

    session = trace.TestTrace(
        metadata={
            "fidelity": fidelity,
            "seed": seed,
            "failing_example": dict(sample),
            "search": "psy-taliro",
        }
    )
    with trace.activate(session):
        requirement.evaluate(simulate(sample, fidelity, seed))
    return tuple(session.save(directory))
