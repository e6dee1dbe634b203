"""Faults of component processes in a running medium-fidelity simulation (the rover's MuJoCo
world and its controller, each a process), each reported naming the component and the fault.
"""

from __future__ import annotations

import os
import shutil
import signal
import time
from typing import Any

import pytest
from fault_helpers import Detections, Trigger, Watcher, at_time, failing, stamped

import multicosim as mcs
import multicosim.rover as rover
from multicosim import testing
from multicosim.local import participant_command

STEP_TIMEOUT = 2.0  # s: short, so that a frozen component is reported soon
FAULT_AT = 5.0  # s of simulated time: the rover is driving its first leg
MISSION = rover.Mission(speed=5.0)
CRASH = 0.0  # a crash has no timeout of its own: it is seen at the next liveness check


Controller = mcs.NodeId[mcs.CommunicationNode[rover.Mission, rover.Trajectory]]


def simulator(*extra: Any) -> tuple[mcs.ProcessSimulator, Controller]:
    """The rover at medium fidelity (world and controller processes), ``extra`` between."""
    sim = mcs.ProcessSimulator(seed=1, step_timeout=STEP_TIMEOUT)
    sim.add(rover.world_component("medium"))
    for component in extra:
        sim.add(component)
    return sim, sim.add(rover.controller_component("medium"))


def faulty(how: str, **kw: Any) -> mcs.ProcessComponent:
    """A ``multicosim.testing.Faulty`` process that misbehaves as ``how`` at FAULT_AT."""
    command = participant_command("multicosim.testing:Faulty", testing.Fault(how, FAULT_AT))
    return mcs.ProcessComponent(["python", "-m", *command], name="faulty", **kw)


def next_run_is_unaffected() -> rover.Trajectory:
    """The same simulation again, without the fault: it completes its mission."""
    sim, controller = simulator()
    with sim.start() as simulation:
        trajectory = simulation.get(controller).send(MISSION)
    assert trajectory.completed, trajectory.reason
    return trajectory


def test_sigkill_mid_step(detections: Detections) -> None:
    sim, controller = simulator(faulty("stuck"))
    with sim.start() as simulation:
        victim = simulation.environment.processes["faulty"]
        # The lockstep is busy inside the component's step: a thread kills it there.
        killer = Watcher(
            lambda: b"stuck at" in victim.read_log(), lambda: os.kill(victim.pid, signal.SIGKILL)
        )
        killer.start()
        error, error_at = failing(
            lambda: simulation.get(controller).send(MISSION), mcs.NodeCrashedError
        )
        fault_at = killer.finish()
    assert (error.name, error.exit_code) == ("faulty", -signal.SIGKILL)
    assert f"crashed (killed by SIGKILL) during its step at t={FAULT_AT:g} s" in str(error)
    assert "stuck at t=5" in error.log_tail
    detections.record("process SIGKILLed mid-step", fault_at, error_at, CRASH, error)
    next_run_is_unaffected()


def test_sigstop_longer_than_the_step_timeout(detections: Detections) -> None:
    pids: dict[str, int] = {}
    freeze = Trigger(at_time(FAULT_AT), lambda: os.killpg(pids["world"], signal.SIGSTOP))
    sim, controller = simulator(mcs.InProcessComponent(lambda: freeze, name="freezer"))
    with sim.start() as simulation:
        pids["world"] = simulation.environment.processes["world"].pid
        error, error_at = failing(
            lambda: simulation.get(controller).send(MISSION), mcs.NodeTimeoutError
        )
    assert freeze.fault_at is not None
    assert error.name == "world"
    assert f"within {STEP_TIMEOUT:g} s: it is frozen (its process is stopped" in str(error)
    detections.record("process frozen (SIGSTOP)", freeze.fault_at, error_at, STEP_TIMEOUT, error)
    next_run_is_unaffected()


class Spin:
    """An in-process participant whose step never returns from FAULT_AT on."""

    period = 0.01

    def __init__(self) -> None:
        self.fault_at: float | None = None

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        if ctx.time >= FAULT_AT:
            self.fault_at = time.monotonic()
        while ctx.time >= FAULT_AT:
            pass


def test_in_process_participant_stuck_in_its_step(detections: Detections) -> None:
    spin = Spin()
    sim, controller = simulator(mcs.InProcessComponent(lambda: spin, name="spin"))
    with sim.start() as simulation:
        error, error_at = failing(
            lambda: simulation.get(controller).send(MISSION), mcs.NodeTimeoutError
        )
    assert spin.fault_at is not None
    assert error.name == "spin"
    assert f"did not finish its step at t={FAULT_AT:g} s within {STEP_TIMEOUT:g} s" in str(error)
    assert "(interrupted in step at test_processes.py:" in str(error)
    detections.record(
        "in-process participant stuck in its step", spin.fault_at, error_at, STEP_TIMEOUT, error
    )
    next_run_is_unaffected()


@pytest.mark.parametrize(
    ("how", "verdict", "code"),
    [
        ("exit", "exited", 0),
        ("raise", f"crashed (it raised RuntimeError: asked to raise at t={FAULT_AT:g})", 1),
    ],
    ids=["exit", "raise"],
)
def test_exit_or_raise_mid_run(detections: Detections, how: str, verdict: str, code: int) -> None:
    sim, controller = simulator(faulty(how))
    with sim.start() as simulation:
        error, error_at = failing(
            lambda: simulation.get(controller).send(MISSION), mcs.NodeCrashedError
        )
    assert (error.name, error.exit_code) == ("faulty", code)
    assert f"'faulty' {verdict} during its step at t={FAULT_AT:g} s" in str(error)
    fault = "process exits with 0 mid-run" if how == "exit" else "process raises in step"
    detections.record(fault, stamped(error.log_tail), error_at, CRASH, error)
    next_run_is_unaffected()


def test_raise_in_setup(detections: Detections) -> None:
    sim, _ = simulator(faulty("setup"))
    error, error_at = failing(sim.start, mcs.NodeStartError)
    assert (error.name, error.exit_code) == ("faulty", 1)
    assert (
        "'faulty' crashed (it raised RuntimeError: asked to fail in setup) before it was ready"
        in str(error)
    )
    detections.record("process raises in setup", stamped(error.log_tail), error_at, CRASH, error)
    next_run_is_unaffected()


def test_unbounded_allocation_hits_the_memory_limit(detections: Detections) -> None:
    sim, controller = simulator(faulty("hog", memory="512m"))
    with sim.start() as simulation:
        error, error_at = failing(
            lambda: simulation.get(controller).send(MISSION), mcs.NodeCrashedError
        )
    assert error.name == "faulty"
    assert "'faulty' ran out of memory (over its limit of 512 MiB) during its step" in str(error)
    assert "MemoryError" in error.log_tail
    detections.record(
        "process out of memory (RLIMIT_AS)", stamped(error.log_tail), error_at, CRASH, error
    )
    next_run_is_unaffected()


def test_run_directory_removed_mid_run(detections: Detections) -> None:
    # Not a failure of the run: its processes hold their files open and run on. The mission
    # ends as an undisturbed one does, and the components' logs are still there to report.
    run_dirs: list[Any] = []
    remove = Trigger(at_time(FAULT_AT), lambda: shutil.rmtree(run_dirs[0]))
    sim, controller = simulator(mcs.InProcessComponent(lambda: remove, name="remover"))
    with sim.start() as simulation:
        run_dirs.append(simulation.run_dir)
        trajectory = simulation.get(controller).send(MISSION)
        assert remove.fault_at is not None
        assert not simulation.run_dir.exists()
        logs = simulation.logs()  # written again from the processes' open files
        assert sorted(logs) == ["controller", "world"]
        assert "serving Firmware('controller'" in logs["controller"].read_text()
    assert not run_dirs[0].exists()
    assert trajectory == next_run_is_unaffected()
    detections.unaffected(
        "run directory removed mid-run",
        "no error: the run goes on to the result of an undisturbed run; the component logs "
        "are written again from the open files for the report",
    )


# A component crashing under a test's fixtures: the report's verdict is the crash, naming the
# component and the fault, with the component's last output beside it.
CRASHING = """
import pytest
import multicosim as mcs
from multicosim import testing
from multicosim.local import participant_command


@pytest.mark.fidelity("medium")
def test_drive(mcs_simulator):
    fault = testing.Fault("raise", at=0.2)
    command = participant_command("multicosim.testing:Faulty", fault)
    mcs_simulator.add(mcs.ProcessComponent(["python", "-m", *command], name="faulty"))
    mcs_simulator.add(mcs.ProcessComponent(
        "python -m multicosim participant multicosim.testing:Cart", name="cart"
    ))
    drive = mcs_simulator.add(mcs.ProcessFirmwareComponent(
        "python -m multicosim serve multicosim.testing:drive --port {port}",
        msgtype=testing.Drive,
    ))
    mcs_simulator.start().get(drive).send(testing.Drive(speed=1.0, steps=20))
"""


def test_crash_under_pytest_is_the_reports_verdict(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_inner=CRASHING)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "--mcs-fidelity=medium")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "verdict: multicosim.NodeCrashedError: component 'faulty' crashed (it raised "
            "RuntimeError: asked to raise at t=0.2) during its step at t=0.2 s (exit code 1)",
            "replay: * -m pytest *test_inner.py::test_drive*",
            "trace: *trace.mcap*",
            "--- faulty: last output (full log: *faulty.log) ---",
            "*RuntimeError: asked to raise at t=0.2",
        ]
    )
