"""multicosim.testing.check_component on a good component and on broken ones."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import check_programs as cp
import pytest

import multicosim as mcs
from multicosim import testing
from multicosim.testing import ComponentReport, check_component

HERE = Path(__file__).parent


@pytest.fixture(autouse=True)
def importable(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Component processes find check_programs; what broken ones leave is cleaned up."""
    path = os.pathsep.join(p for p in (str(HERE), os.environ.get("PYTHONPATH")) if p)
    monkeypatch.setenv("PYTHONPATH", path)
    cp.RELEASE.clear()
    yield
    cp.RELEASE.set()
    for process in cp.SPAWNED:
        process.kill()
        process.wait()
    cp.SPAWNED.clear()


def failed(report: ComponentReport) -> dict[str, str]:
    return {check.name: check.detail for check in report.failures}


def test_a_good_participant_passes_every_check() -> None:
    report = check_component(cp.Noisy, duration=0.2, seed=3)
    assert report.passed
    names = [check.name for check in report.checks]
    assert names == [
        "runs in-process",
        "stops idempotently (in-process)",
        "leaves nothing behind (in-process)",
        "deterministic for seed 3",
        "runs as a process",
        "stops idempotently (as a process)",
        "leaves nothing behind (as a process)",
        "the same in-process and as a process",
    ]
    assert str(report).startswith("check_component(check_programs:Noisy):\n  ok   runs in-process")


def test_a_configured_participant_gets_its_configuration_both_ways() -> None:
    report = check_component("check_programs:Configured", config=cp.Config(speed=2.0), duration=0.1)
    assert report.passed, str(report)


def test_a_good_firmware_with_its_world_beside_it_passes() -> None:
    report = check_component(
        testing.drive,
        message=testing.Drive(speed=1.0, steps=10),
        beside=lambda: [mcs.InProcessComponent(testing.Cart, name="cart")],
    )
    assert report.passed, str(report)


def test_unseeded_randomness_fails_determinism() -> None:
    with pytest.raises(mcs.ComponentCheckError) as caught:
        check_component(cp.Unseeded, duration=0.1)
    failures = failed(caught.value.report)
    assert set(failures) == {"deterministic for seed 0", "the same in-process and as a process"}
    assert "message 0 differs: 'state' at t=0 s" in failures["deterministic for seed 0"]
    assert "FAIL deterministic for seed 0" in str(caught.value)


def test_a_thread_left_running_is_reported() -> None:
    report = check_component(cp.LeavesAThread, duration=0.05, raise_on_failure=False)
    assert set(failed(report)) == {"leaves nothing behind (in-process)"}
    assert "thread 'left-behind' still runs" in failed(report)["leaves nothing behind (in-process)"]


def test_a_child_process_left_running_is_reported() -> None:
    report = check_component(cp.LeavesAProcess, duration=0.05, raise_on_failure=False)
    # In a process of its own the child dies with the component's process group.
    assert set(failed(report)) == {"leaves nothing behind (in-process)"}
    detail = failed(report)["leaves nothing behind (in-process)"]
    assert f"process {cp.SPAWNED[0].pid}" in detail
    assert "time.sleep(600)" in detail


def test_behaviour_that_depends_on_the_host_process_is_reported() -> None:
    report = check_component(cp.KnowsWhereItRuns, duration=0.05, raise_on_failure=False)
    assert set(failed(report)) == {"the same in-process and as a process"}
    assert "with other content" in failed(report)["the same in-process and as a process"]


def test_a_failing_firmware_is_reported_with_its_error() -> None:
    report = check_component(
        cp.fails, message=testing.Drive(speed=1.0, steps=1), raise_on_failure=False
    )
    failures = failed(report)
    assert set(failures) == {"runs in-process", "runs as a process"}
    assert "this firmware always fails" in failures["runs in-process"]
    assert "this firmware always fails" in failures["runs as a process"]


def test_a_component_a_process_cannot_import_is_reported() -> None:
    class Local(cp.Noisy):
        pass

    report = check_component(Local, duration=0.05, raise_on_failure=False)
    assert set(failed(report)) == {"runs as a process"}
    assert "define it at the top level of a module" in failed(report)["runs as a process"]


def test_a_node_that_cannot_be_stopped_twice_is_reported() -> None:
    report = check_component(cp.StopsOnce(), duration=0.05, raise_on_failure=False)
    assert set(failed(report)) == {"stops idempotently"}
    assert "already stopped" in failed(report)["stops idempotently"]


def test_bad_arguments_are_refused_before_anything_runs() -> None:
    with pytest.raises(mcs.ConfigurationError) as caught:
        check_component(testing.drive)
    assert caught.value.field == "message"
    with pytest.raises(mcs.ConfigurationError) as caught:
        check_component(cp.Noisy, duration=0)
    assert caught.value.field == "duration"
    report = check_component("no_such_module:Thing", raise_on_failure=False)
    assert set(failed(report)) == {"runs in-process", "runs as a process"}
    assert "ModuleNotFoundError" in failed(report)["runs in-process"]
