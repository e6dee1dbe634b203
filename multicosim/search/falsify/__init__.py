"""Falsification: search a space of inputs for a violation, cheaply, and confirm it higher up.

```python
from multicosim.search.falsify import Choice, Integer, falsify

def simulate(sample, fidelity, seed):            # one simulation -> its trajectory
    world = WorldConfig(timestep=sample["timestep"], iterations=sample["iterations"])
    with rover.Rover(fidelity=fidelity, seed=seed, world=world).start() as simulation:
        return simulation.controller.send(rover.Mission(speed=sample["speed"]))

space = {
    "speed": (1.0, 10.0),                        # a real interval
    "iterations": Integer(10, 200),              # whole numbers, both ends included
    "timestep": Choice(0.001, 0.002, 0.005),     # one of these values
}
result = falsify(simulate, "always (roll <= 0.3)", space, levels=("low", "medium"))
result.first_violation               # simulations until the first violation
result.counterexample.failing_levels # ("low", "medium"): confirmed at medium fidelity
print(result.summary())
```

**Search.** Every sample is one simulation at the search level (``levels[0]``), scored by
the requirement's robustness, which the optimizer minimizes. ``optimizer`` is a name
([`OPTIMIZERS`][multicosim.search.falsify.OPTIMIZERS]: optuna's samplers ``"random"``, ``"tpe"``,
``"cmaes"``, ``"gp"``, a Latin hypercube ``"lhs"``, ``"hypothesis"`` and psy-taliro's
``"taliro-random"`` and ``"taliro-annealing"``), an optuna sampler, a psy-taliro optimizer, or any
object with ``ask()`` (a sample: a mapping, or values in the space's order) and
``tell(sample, robustness)``; by default (None) ``"gp"``, the one that needed the fewest
simulations on the shipped benchmark, where torch is installed (``pip install
'multicosim[gp]'``), else ``"tpe"``. ``space`` may also be a Hypothesis strategy, searched by
``"hypothesis"``. ``budget`` bounds the search-level simulations; ``seed`` fixes the
optimizer and is every simulation's seed, so a seed repeats a search exactly.

**Multi-fidelity.** A sample that violates the requirement is re-run at each further level
in turn (``levels`` are fidelity names, or [`Level`][multicosim.search.falsify.Level] objects that
bring their own simulate function: real firmware, say). It is the counterexample once every level
confirms it; where one does not, the search goes on and the optimizer is told that level's
robustness for the sample instead, so it learns where the cheap model is wrong. The result
tells per level how often a violation transferred, and the wall time saved against
searching at the confirming level alone.

**Configuration as search variables.** The space may hold the simulator's configuration
(timestep, solver iterations, noise levels, attack parameters) like any input, and the
fidelity itself: a ``"fidelity"`` dimension (``Choice("low", "medium")``) runs each sample at
the level drawn. The counterexample is then re-run at the levels below the one it was found
at, and [`Counterexample.lowest_failing`][multicosim.search.falsify.Counterexample.lowest_failing]
names the lowest fidelity that still falsifies.

One callback shape throughout multicosim: ``simulate(sample, fidelity, seed)``, as for
campaigns ([`multicosim.search.campaign`][multicosim.search.campaign]) and psy-taliro
([`multicosim.search.taliro`][multicosim.search.taliro]).

The package's modules, one concern each: [`space`][multicosim.f16.arch.Benchmark.space], ``levels``,
``search`` (the objective), ``optimizers`` (one adapter module per optimizer, behind
``optimizers.protocol``), ``results`` and ``run`` ([`falsify`][multicosim.search.falsify.falsify]).
"""

from __future__ import annotations

from ..campaign.simulate import Simulate
from .levels import Level
from .optimizers import (
    DEFAULT_OPTIMIZER,
    FALLBACK_OPTIMIZER,
    OPTIMIZERS,
    AskTell,
    HypothesisSearch,
)
from .optimizers import default_optimizer as default_optimizer
from .results import (
    Counterexample,
    FalsificationResult,
    LevelResult,
    LevelStats,
    Trial,
    first_violation_statistics,
)
from .run import falsify
from .space import FIDELITY, Choice, Integer, Real
from .space import Dimension as Dimension

# As before the split: default_optimizer and Dimension importable from here, not star-exported.
__all__ = [
    "DEFAULT_OPTIMIZER",
    "FALLBACK_OPTIMIZER",
    "FIDELITY",
    "OPTIMIZERS",
    "AskTell",
    "Choice",
    "Counterexample",
    "FalsificationResult",
    "HypothesisSearch",
    "Integer",
    "Level",
    "LevelResult",
    "LevelStats",
    "Real",
    "Simulate",
    "Trial",
    "falsify",
    "first_violation_statistics",
]
