"""psy-taliro samples evaluated through a campaign executor."""

from __future__ import annotations

import campaign_programs as cp
import pytest

import multicosim.search.taliro as mtaliro
from multicosim.search.campaign import ProcessExecutor


def test_taliro_batches_run_in_the_pool_like_in_process() -> None:
    staliro_optimizers = pytest.importorskip("staliro.optimizers")
    kwargs = {
        "static_inputs": dict(cp.RANGES),
        "iterations": 30,
        "seed": 2,
        "optimizer": staliro_optimizers.UniformRandom(),
    }
    pooled = mtaliro.falsify(
        cp.simulate_rover, cp.REQUIREMENT, executor=ProcessExecutor(workers=2), **kwargs
    )
    local = mtaliro.falsify(cp.simulate_rover, cp.REQUIREMENT, **kwargs)
    # The pool gives each sample the seed of its index, this process the search's seed:
    # ideal sensors at low fidelity make the seed irrelevant, so the results agree.
    assert pooled.evaluations == local.evaluations == 30
    costs = [e.cost for run in pooled.runs for e in run.evaluations]
    assert costs == [e.cost for run in local.runs for e in run.evaluations]
    assert pooled.falsified
    assert pooled.sample == local.sample
    assert pooled.evaluation.robustness == pooled.robustness < 0
