"""Everywhere an FMU runs: in-process, as a local process, in a container. An FMU that
fails is an error naming it, its call, status and time; one that crashes is a
NodeCrashedError with its log, not the end of the test process; nothing is left behind."""

from __future__ import annotations

import signal
from collections.abc import Callable
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmu_helpers import FAULT_TIME

import multicosim as mcs
from multicosim import fmi
from pytest_multicosim.docker import require_docker

STOP = 5.0


def _run(component: fmi.FMU, simulator: object | None = None) -> tuple[object, Path]:
    sim = simulator or mcs.ProcessSimulator()
    node_id = sim.add(component)  # type: ignore[attr-defined]
    with sim.start() as simulation:  # type: ignore[attr-defined]
        simulation.advance(STOP + component.config.period / 2)
        return simulation.get(node_id).result(), simulation.run_dir


@pytest.mark.parametrize("where", ["in-process", "process"])
def test_an_fmu_runs_where_asked(reference_fmus: Path, where: str, no_leaks: None) -> None:
    path = reference_fmus / "fmi3" / "VanDerPol.fmu"
    result, run_dir = _run(fmi.FMU(path, name="vdp", placement=where, stop_time=STOP))
    reference = fmpy.simulate_fmu(str(path), stop_time=STOP, output_interval=0.01)
    np.testing.assert_array_equal(result["x0"], reference["x0"])  # type: ignore[index]
    assert not run_dir.exists()  # extracted files and logs went with the run


def test_an_fmu_runs_in_a_container(reference_fmus: Path, mcs_runtime_image: str) -> None:
    from multicosim.docker import ContainerSimulator
    from multicosim.docker.engine import LABEL_RUN, client

    path = reference_fmus / "fmi2" / "BouncingBall.fmu"
    simulator = ContainerSimulator()
    node_id = simulator.add(fmi.FMU(path, name="ball", placement="docker", stop_time=STOP))
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        assert [c.name for c in simulation.containers()] == ["ball"]
        simulation.advance(STOP + 0.005)
        result = node.result()
        run_id = simulation.run_id
    reference = fmpy.simulate_fmu(str(path), stop_time=STOP, output_interval=0.01)
    np.testing.assert_array_equal(result["h"], reference["h"])
    left = client().api.containers(all=True, filters={"label": f"{LABEL_RUN}={run_id}"})
    assert left == []


@pytest.mark.parametrize(
    ("fault", "status"), [("error", "Error"), ("fatal", "Fatal"), ("discard", "Discard")]
)
def test_a_failing_step_in_process_is_an_fmu_error(
    faulty_fmu: Callable[[str], Path], fault: str, status: str
) -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(fmi.FMU(faulty_fmu(fault), name="dahlquist", period=0.1))
    with simulator.start() as simulation:
        with pytest.raises(fmi.FMUError) as info:
            simulation.advance(2.0)
        node = simulation.get(node_id)
        logs = simulation.logs()
        log_text = logs["dahlquist"].read_text()
        participant = node.node.participant  # type: ignore[attr-defined]
        assert participant.done  # it steps no more
    error = info.value
    assert (error.name, error.function, error.status) == ("dahlquist", "fmi2DoStep", status)
    assert error.time == pytest.approx(FAULT_TIME)
    assert f"returned {status} at t=0.5 s" in str(error)
    assert "injected" in error.log_tail
    if status != "Discard":  # a Discard is no failure of the FMU's own: it logs no reason
        assert error.fmu_reason.startswith("injected")
        assert str(error).splitlines()[0].endswith(error.fmu_reason)
    assert "injected" in log_text  # the component's log
    assert node.result()["time"][-1] == pytest.approx(0.4)  # its last good instant


def test_the_error_names_the_simulated_time_and_the_fmus(
    faulty_fmu: Callable[[str], Path],
) -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(fmi.FMU(faulty_fmu("error"), name="dahlquist", period=0.1, start_time=0.3))
    with simulator.start() as simulation, pytest.raises(fmi.FMUError) as info:
        simulation.advance(2.0)
    # The FMU's time starts at 0.3 s: its fault (from its 0.5 s on) comes at 0.2 s.
    assert info.value.time == pytest.approx(0.2)
    assert info.value.fmu_time == pytest.approx(0.5)
    assert "at t=0.2 s (the FMU's time 0.5 s)" in str(info.value)


def test_a_failing_step_in_a_process_is_a_crash_with_the_error(
    faulty_fmu: Callable[[str], Path], no_leaks: None
) -> None:
    component = fmi.FMU(faulty_fmu("error"), name="dahlquist", period=0.1, placement="process")
    with pytest.raises(mcs.NodeCrashedError) as info:
        _run(component)
    error = info.value
    assert (error.name, error.exit_code) == ("dahlquist", 1)
    assert "exited during its step at t=0.5 s" in str(error)
    assert "[Error] logStatusError: injected fault at t=0.5" in error.log_tail
    assert "fmi2DoStep returned Error at t=0.5 s" in error.log_tail


def test_an_fmu_that_aborts_is_a_crash_not_a_dead_test_process(
    faulty_fmu: Callable[[str], Path], no_leaks: None
) -> None:
    component = fmi.FMU(faulty_fmu("abort"), name="dahlquist", period=0.1, placement="process")
    simulator = mcs.ProcessSimulator()
    simulator.add(component)
    simulation = simulator.start()
    run_dir = simulation.run_dir
    try:
        with pytest.raises(mcs.NodeCrashedError) as info:
            simulation.advance(2.0)
    finally:
        simulation.stop()
    error = info.value
    assert (error.name, error.exit_code) == ("dahlquist", -signal.SIGABRT)
    assert "crashed (killed by SIGABRT) during its step at t=0.5 s" in str(error)
    assert "injected fault: aborting at t=0.5" in error.log_tail  # the FMU's log, kept
    assert not run_dir.exists()


def test_an_fmu_that_aborts_in_a_container(
    faulty_fmu: Callable[[str], Path], mcs_runtime_image: str
) -> None:
    require_docker()
    from multicosim.docker import ContainerSimulator
    from multicosim.docker.engine import LABEL_RUN, client

    component = fmi.FMU(faulty_fmu("abort"), name="dahlquist", period=0.1, placement="docker")
    simulator = ContainerSimulator()
    simulator.add(component)
    simulation = simulator.start()
    run_id = simulation.run_id
    with pytest.raises(mcs.NodeCrashedError) as info:
        simulation.advance(2.0)
    # The crash was reported once; stopping removes everything without reporting it again.
    simulation.stop()
    assert info.value.name == "dahlquist"
    assert info.value.exit_code not in (None, 0)
    assert "injected fault: aborting at t=0.5" in info.value.log_tail
    left = client().api.containers(all=True, filters={"label": f"{LABEL_RUN}={run_id}"})
    assert left == []


def test_a_container_fmu_needs_a_container_simulator(reference_fmus: Path) -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(fmi.FMU(reference_fmus / "fmi2" / "Dahlquist.fmu", placement="docker"))
    with pytest.raises(mcs.ConfigurationError, match="a simulator of the docker placement"):
        simulator.start()


def test_multicosim_images_build_builds_an_fmus_image(
    reference_fmus: Path, mcs_runtime_image: str
) -> None:
    import subprocess
    import sys

    from multicosim.docker.engine import client

    path = reference_fmus / "fmi2" / "Dahlquist.fmu"
    done = subprocess.run(
        [sys.executable, "-m", "multicosim", "images", "build", "--fmu", str(path)],
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    tag = done.stdout.split()[-1]
    assert tag == fmi.build_image(path)  # the same inputs, the same image (not rebuilt)
    files = client().containers.run(tag, ["ls", "/opt/fmu"], remove=True).decode()
    assert files.split() == ["Dahlquist.fmu"]
