"""Campaigns in the local process pool: designs, results, retries, timeouts, bad input."""

from __future__ import annotations

import csv
import os
import signal
import threading
import time
from pathlib import Path
from typing import Any

import campaign_programs as cp
import pytest
from hypothesis import strategies as st

import multicosim as mcs
from multicosim.search.campaign import (
    ProcessExecutor,
    from_strategy,
    latin_hypercube,
    random_design,
    run_campaign,
    sample_seed,
)


def kill_when_parked(victim: Path, killed: list[int]) -> threading.Thread:
    """Kill the process whose pid appears in ``victim`` (it sleeps there mid-simulation)."""

    def watch() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if victim.exists() and victim.read_text():
                pid = int(victim.read_text())
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.01)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread


def outcomes(results: Any) -> list[tuple[Any, ...]]:
    """What must not depend on the executor or the order of completion."""
    return [(r.index, r.seed, r.status, r.robustness, dict(r.summary)) for r in results]


def test_latin_hypercube_has_one_sample_per_stratum() -> None:
    design = latin_hypercube({"a": (0.0, 10.0), "b": (-1.0, 1.0)}, 20, seed=4)
    assert len(design) == 20
    strata = sorted(int((s["a"] - 0.0) / 10.0 * 20) for s in design)
    assert strata == list(range(20))
    assert design == latin_hypercube({"a": (0.0, 10.0), "b": (-1.0, 1.0)}, 20, seed=4)
    assert design != latin_hypercube({"a": (0.0, 10.0), "b": (-1.0, 1.0)}, 20, seed=5)


def test_random_design_and_strategy_samples_repeat_for_a_seed() -> None:
    design = random_design({"speed": (1.0, 2.0)}, 30, seed=1)
    assert design == random_design({"speed": (1.0, 2.0)}, 30, seed=1)
    assert all(1.0 <= s["speed"] <= 2.0 for s in design)
    strategy = st.fixed_dictionaries({"speed": st.floats(1.0, 8.0), "distance": st.just(3.0)})
    drawn = from_strategy(strategy, 25, seed=7)
    assert len(drawn) == 25
    assert drawn == from_strategy(strategy, 25, seed=7)


def test_seeds_depend_on_campaign_seed_and_index_only() -> None:
    seeds = [sample_seed(3, i) for i in range(100)]
    assert len(set(seeds)) == 100
    assert seeds == [sample_seed(3, i) for i in range(100)]
    assert sample_seed(4, 0) != seeds[0]


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: run_campaign(cp.simulate_rover, cp.REQUIREMENT, []), "samples"),
        (lambda: latin_hypercube({}, 5), "ranges"),
        (lambda: latin_hypercube({"speed": (8.0, 1.0)}, 5), "ranges['speed']"),
        (lambda: random_design({"speed": (1.0, 1.0)}, 5), "ranges['speed']"),
        (lambda: random_design({"speed": (1.0, 2.0)}, 0), "n"),
        (
            lambda: run_campaign(cp.simulate_rover, cp.REQUIREMENT, [{}], executor="dask"),
            "executor",
        ),
        (
            lambda: run_campaign(
                cp.simulate_rover, cp.REQUIREMENT, [{}], executor="process", ray_address="auto"
            ),
            "ray_address",
        ),
        (lambda: run_campaign(cp.simulate_rover, cp.REQUIREMENT, [{}], timeout=0), "timeout"),
        (lambda: run_campaign(cp.simulate_rover, cp.REQUIREMENT, [{}], fidelity="x"), "fidelity"),
        (lambda: ProcessExecutor(context="fork"), "context"),
    ],
)
def test_bad_input_names_the_field(call: Any, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        call()
    assert info.value.field == field


def test_pool_campaign_writes_results_and_traces(tmp_path: Path) -> None:
    design = latin_hypercube(cp.RANGES, 50, seed=3)
    streamed: list[int] = []
    result = run_campaign(
        cp.simulate_rover,
        cp.REQUIREMENT,
        design,
        executor=ProcessExecutor(workers=2),
        output=tmp_path,
        on_result=lambda r: streamed.append(r.index),
    )
    assert [r.index for r in result.results] == list(range(50))
    assert sorted(streamed) == list(range(50))
    assert {r.status for r in result.results} == {"ok", "violated"}
    for r in result.results:
        # The requirement bounds the speed: its robustness is the margin to the fastest sample.
        assert r.robustness == pytest.approx(4.5 - r.summary["speed_max"])
        assert r.summary["completed"] is True
        assert bool(r.trace) == (r.status == "violated")
        assert all(p.exists() for p in r.trace)
    with (tmp_path / "results.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert [int(row["index"]) for row in rows] == list(range(50))
    assert [row["status"] for row in rows] == [r.status for r in result.results]
    assert float(rows[0]["sample.speed"]) == design[0]["speed"]


def test_pool_retries_a_killed_worker(tmp_path: Path) -> None:
    design: list[dict[str, Any]] = [dict(s) for s in latin_hypercube(cp.RANGES, 12, seed=3)]
    victim = tmp_path / "victim.pid"
    design[5]["victim"] = str(victim)
    killed: list[int] = []
    watcher = kill_when_parked(victim, killed)
    result = run_campaign(
        cp.simulate_or_die, cp.REQUIREMENT, design, executor=ProcessExecutor(workers=2)
    )
    watcher.join()
    assert killed
    assert all(r.status in ("ok", "violated") for r in result.results)
    assert result.results[5].attempts == 2
    assert any(e.index == 5 and e.attempt == 1 for e in result.retries)
    plain = latin_hypercube(cp.RANGES, 12, seed=3)
    reference = run_campaign(cp.simulate_rover, cp.REQUIREMENT, plain, executor="process")
    assert outcomes(result.results) == outcomes(reference.results)


def test_pool_cancels_a_hanging_simulation() -> None:
    design: list[dict[str, Any]] = [dict(s) for s in latin_hypercube(cp.RANGES, 6, seed=3)]
    design[2]["hang"] = True
    # The flagged sample sleeps for an hour: that the campaign returns at all means it was cut.
    result = run_campaign(
        cp.simulate_or_hang, cp.REQUIREMENT, design, executor=ProcessExecutor(workers=2), timeout=2
    )
    assert result.results[2].status == "timeout"
    assert "timeout" in result.results[2].error
    assert [r.status for i, r in enumerate(result.results) if i != 2] == [
        "ok" if r.robustness >= 0 else "violated" for i, r in enumerate(result.results) if i != 2
    ]


def test_a_progress_bar_on_request_and_quiet_otherwise(capfd: pytest.CaptureFixture[str]) -> None:
    design = latin_hypercube(cp.RANGES, 4, seed=1)
    run_campaign(
        cp.simulate_rover,
        cp.REQUIREMENT,
        design,
        executor=ProcessExecutor(workers=1),
        progress=True,
    )
    err = capfd.readouterr().err
    assert "campaign [process]" in err
    assert "4/4" in err
    assert "best robustness" in err
    # stderr is no terminal here: by default, nothing.
    run_campaign(cp.simulate_rover, cp.REQUIREMENT, design, executor=ProcessExecutor(workers=1))
    assert capfd.readouterr().err == ""


def test_a_simulate_function_of_another_shape_is_refused() -> None:
    def two_arguments(sample: Any, fidelity: str) -> object:
        raise AssertionError("must not run")

    with pytest.raises(mcs.ConfigurationError, match=r"simulate\(sample, fidelity, seed\)"):
        run_campaign(two_arguments, cp.REQUIREMENT, [{"speed": 1.0}])  # type: ignore[arg-type]
