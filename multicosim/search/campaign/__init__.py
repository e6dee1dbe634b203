"""Campaigns: a batch of samples evaluated as simulations, in a local process pool or on Ray.

```python
from multicosim.search.campaign import latin_hypercube, run_campaign

def simulate(sample, fidelity, seed):           # one simulation -> its trajectory
    with rover.Rover(fidelity=fidelity, seed=seed).start() as simulation:
        return simulation.controller.send(rover.Mission(speed=sample["speed"]))

design = latin_hypercube({"speed": (1.0, 10.0)}, 200, seed=1)
result = run_campaign(simulate, "always (z > -0.1)", design, output="campaign")
result.violations, result.rate_per_minute   # campaign/results.csv, campaign/traces/...
```

Each sample runs ``simulate(sample, fidelity, seed)`` in a worker; its seed derives from the
campaign seed and the sample's index ([`sample_seed`][multicosim.search.campaign.sample_seed]),
never from the order in which samples finish, so a campaign gives the same results on any executor.
A worker returns the requirement's robustness, a summary of the trajectory and, for a sample that
violates the requirement, fails or times out, its MCAP trace. Results stream back as they finish
(``on_result``, a progress bar on a terminal) and are written as ``results.csv`` (and
``results.parquet`` where pyarrow is installed) with the traces under ``output``.

Executors: ``"process"`` (default; a ``concurrent.futures`` pool of forkserver processes) and
``"ray"`` / ``ray_address=...`` (Ray tasks; each simulation uses the process backend on its
worker). A worker that dies is retried ``max_retries`` times and reported in
``CampaignResult.retries``; a sample still running at ``timeout`` is cancelled; Ctrl-C stops
every task, writes what finished and raises
[`CampaignInterrupted`][multicosim.search.campaign.CampaignInterrupted] carrying it.
[`Campaign`][multicosim.search.campaign.Campaign] keeps an executor open for optimizers that ask for
batches.

The package's modules, one concern each: ``simulate`` (the callback and the seeds),
``designs``, ``worker`` (what a worker runs), ``executors`` (one module per
executor, behind ``executors.protocol``), ``driver``
([`Campaign`][multicosim.search.campaign.Campaign]), ``results`` and ``output`` (``results.csv``,
the traces).
"""

from __future__ import annotations

from .designs import from_strategy, latin_hypercube, random_design
from .driver import Campaign, CampaignInterrupted, run_campaign
from .executors import ExecutorSpec, ProcessExecutor, RayExecutor
from .results import STATUSES, CampaignResult, RetryEvent, SampleResult
from .simulate import Simulate, check_simulate, sample_seed
from .worker import summarize

__all__ = [
    "STATUSES",
    "Campaign",
    "CampaignInterrupted",
    "CampaignResult",
    "ExecutorSpec",
    "ProcessExecutor",
    "RayExecutor",
    "RetryEvent",
    "SampleResult",
    "Simulate",
    "check_simulate",
    "from_strategy",
    "latin_hypercube",
    "random_design",
    "run_campaign",
    "sample_seed",
    "summarize",
]
