"""Campaigns as Ray tasks on a local, loopback-only cluster (one per module)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import campaign_programs as cp
import pytest
from test_campaign import kill_when_parked, outcomes

from multicosim.search.campaign import RayExecutor, latin_hypercube, run_campaign

ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'multicosim[ray]')")

# One cluster for the module: tests of it must share an xdist worker.
pytestmark = pytest.mark.xdist_group("ray")


@pytest.fixture(scope="module")
def cluster() -> Iterator[RayExecutor]:
    """A two-CPU local Ray cluster on loopback; shut down whatever the tests did."""
    # The test helpers are not installed: ship them to the workers by value.
    ray.cloudpickle.register_pickle_by_value(cp)
    try:
        ray.init(
            num_cpus=2,
            include_dashboard=False,
            _node_ip_address="127.0.0.1",
            log_to_driver=False,
            configure_logging=False,
        )
        yield RayExecutor()  # uses the connection made here
    finally:
        ray.shutdown()
        ray.cloudpickle.unregister_pickle_by_value(cp)


def test_ray_campaign_matches_the_process_pool(cluster: RayExecutor, tmp_path: Path) -> None:
    design = latin_hypercube(cp.RANGES, 60, seed=3)
    on_ray = run_campaign(
        cp.simulate_rover, cp.REQUIREMENT, design, executor=cluster, output=tmp_path
    )
    local = run_campaign(cp.simulate_rover, cp.REQUIREMENT, design, executor="process")
    assert on_ray.executor == "ray"
    assert len(on_ray.results) == 60
    assert {r.status for r in on_ray.results} == {"ok", "violated"}
    assert outcomes(on_ray.results) == outcomes(local.results)
    pids = {r.worker for r in on_ray.results}
    assert os.getpid() not in {int(w.rsplit(":", 1)[1]) for w in pids}
    assert (tmp_path / "results.csv").exists()
    assert all(p.exists() for r in on_ray.violations for p in r.trace)


def test_ray_retries_a_killed_worker(cluster: RayExecutor, tmp_path: Path) -> None:
    pid = ray.get(ray.remote(cp.worker_pid).remote())
    assert pid != os.getpid()  # a worker of its own, which is what the campaign will kill
    design: list[dict[str, Any]] = [dict(s) for s in latin_hypercube(cp.RANGES, 50, seed=3)]
    victim = tmp_path / "victim.pid"
    design[20]["victim"] = str(victim)
    killed: list[int] = []
    watcher = kill_when_parked(victim, killed)
    result = run_campaign(cp.simulate_or_die, cp.REQUIREMENT, design, executor=cluster)
    watcher.join()
    assert killed
    assert all(r.status in ("ok", "violated") for r in result.results)  # every sample
    assert result.results[20].attempts == 2
    assert [(e.index, e.attempt) for e in result.retries] == [(20, 1)]
    assert "died" in result.retries[0].reason
    reference = run_campaign(
        cp.simulate_rover, cp.REQUIREMENT, latin_hypercube(cp.RANGES, 50, seed=3)
    )
    assert outcomes(result.results) == outcomes(reference.results)


def test_ray_cancels_a_hanging_simulation(cluster: RayExecutor) -> None:
    design: list[dict[str, Any]] = [dict(s) for s in latin_hypercube(cp.RANGES, 6, seed=3)]
    design[1]["hang"] = True
    # The flagged sample sleeps for an hour: that the campaign returns at all means it was cut.
    result = run_campaign(cp.simulate_or_hang, cp.REQUIREMENT, design, executor=cluster, timeout=2)
    assert result.results[1].status == "timeout"
    assert all(r.status in ("ok", "violated") for i, r in enumerate(result.results) if i != 1)
