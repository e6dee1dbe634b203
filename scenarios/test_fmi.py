"""Regression suite of FMUs as components: an FMU plant in a loop with a controller of ours,
an FMU environment model beside the MuJoCo world, and a search over an FMU's parameters.

The FMUs are the Modelica Association's Reference FMUs (``reference_fmus``: skipped, with
the reason, where they are absent); they run where the fidelity and backend say (``fmu``
fixture: in-process at low, as processes above, containers on the docker backend)::

    pytest scenarios/test_fmi.py --mcs-fidelity=low,medium

Assertions are on simulated quantities, against an analytic answer and against FMPy running
the same FMU alone (its own simulation loop, fed the same inputs).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import fmpy
import numpy as np
import pytest

import multicosim as mcs
import multicosim.attacks as attacks
import multicosim.rover as rover
from multicosim import fmi
from multicosim.core.fidelity import check_fidelity
from multicosim.placement import default_placement
from multicosim.search.falsify import falsify
from pytest_multicosim.fmi import FMUFactory

# StateSpace as three independent first-order plants x' = a x + b u, y = x, each of unit
# gain (b = -a): time constants 2 s, 1 s and 0.5 s. Its model description states a fixed
# internal step of 1 s, so it communicates every second (its C code integrates at 1 ms).
POLES = np.array([-0.5, -1.0, -2.0])
PLANT = {"A": np.diag(POLES), "B": np.diag(-POLES), "C": np.eye(3), "D": np.zeros((3, 3))}
GAIN = 0.5
SETPOINT = [1.0, 2.0, -1.0]


class Controller:
    """A proportional controller of ours: ``u = gain * (setpoint - y)`` every second."""

    period = 1.0

    def __init__(self, gain: float, setpoint: list[float]) -> None:
        self.gain = gain
        self.setpoint = setpoint

    def setup(self, ctx: mcs.StepContext) -> None:
        """Read the plant's output."""
        self.y = ctx.subscribe("plant/y", list[float])

    def step(self, ctx: mcs.StepContext) -> None:
        """Command the plant from its latest output."""
        y = self.y.latest
        if y is not None:
            u = [self.gain * (r - v) for r, v in zip(self.setpoint, y, strict=True)]
            ctx.publish("plant/u", u)


@pytest.mark.fidelity("low", "medium", "high")
def test_a_controller_of_ours_closes_the_loop_around_an_fmu_plant(
    fmu: FMUFactory, reference_fmus: Path
) -> None:
    path = reference_fmus / "fmi3" / "StateSpace.fmu"
    simulator = fmu.simulator()
    plant = simulator.add(
        fmu(
            path,
            name="plant",
            parameters=PLANT,
            inputs={"u": "plant/u"},
            outputs={"y": "plant/y"},
            record=["u"],
        )
    )
    simulator.add(mcs.InProcessComponent(lambda: Controller(GAIN, SETPOINT), name="controller"))
    simulation = simulator.start()
    simulation.advance(40.5)
    result = simulation.get(plant).result()

    # Analytic: at rest, y = u (unit gain) and u = K (r - y), so y = K r / (1 + K).
    np.testing.assert_allclose(result["y"][-1], GAIN * np.array(SETPOINT) / (1 + GAIN), atol=1e-6)
    # FMPy, running the plant alone and fed the inputs it was given here, computes the
    # same outputs: the loop changes what goes in, never how the FMU steps.
    inputs = np.zeros(len(result), dtype=[("time", np.float64), ("u", np.float64, (3,))])
    inputs["time"], inputs["u"] = result["time"], result["u"]
    alone = fmpy.simulate_fmu(
        str(path),
        stop_time=40.0,
        output_interval=1.0,
        start_values={name: value.ravel().tolist() for name, value in PLANT.items()},
        input=inputs,
        output=["y"],
    )
    np.testing.assert_allclose(result["y"], alone["y"], rtol=1e-12, atol=1e-12)


# A GPS error model: StateSpace as a first-order lag (time constant 2 s) towards an offset of
# 2 m east and 1 m south, the receiver's error building up as the vehicle drives.
TAU = 2.0
ERROR_MODEL = {
    "A": -np.eye(3) / TAU,
    "B": np.eye(3) / TAU,
    "C": np.eye(3),
    "D": np.zeros((3, 3)),
}
ERROR_TARGET = [2.0, -1.0, 0.0]


class Probe:
    """Keeps every rover position published on ``topic``, with its time."""

    def __init__(self, topic: str, period: float) -> None:
        self.topic, self.period = topic, period
        self.readings: list[tuple[float, rover.Position]] = []

    def setup(self, ctx: mcs.StepContext) -> None:
        self.sub = ctx.subscribe(self.topic, rover.Position)

    def step(self, ctx: mcs.StepContext) -> None:
        self.readings.extend((ctx.time, p) for p in self.sub.messages)


@pytest.mark.fidelity("medium", "high")
def test_an_fmu_environment_model_feeds_the_rovers_gps(
    fmu: FMUFactory, reference_fmus: Path, rover_simulator: rover.Rover
) -> None:
    path = reference_fmus / "fmi3" / "StateSpace.fmu"
    error = rover_simulator.add(
        fmu(
            path,
            name="gps_error",
            parameters=ERROR_MODEL,
            start_values={"u": ERROR_TARGET},
            outputs={"y": "gps/error"},
        )
    )
    # The injector's way into the vehicle: the world publishes its GPS on a raw topic, the
    # injector adds the FMU's latest output and publishes where the controller reads.
    injector = attacks.inject(rover_simulator, "gps", [attacks.Stream(topic="gps/error")])
    period = rover_simulator.config.world.period
    raw, read = Probe(injector.config.source, period), Probe(injector.config.target, period)
    rover_simulator.add(mcs.InProcessComponent(lambda: raw, name="raw"))
    rover_simulator.add(mcs.InProcessComponent(lambda: read, name="read"))
    simulation = rover_simulator.start()
    trajectory = simulation.controller.send(
        rover.Mission(speed=3.0, wait=1.0, distance=5.0, final_distance=5.0)
    )
    assert trajectory.completed, trajectory.reason
    outputs = simulation.get(error).result()

    # What the controller read is the world's reading plus the FMU's output of that second.
    assert len(read.readings) == len(raw.readings) > 100
    for (t, measured), (_, seen) in zip(raw.readings, read.readings, strict=True):
        y = outputs["y"][np.searchsorted(outputs["time"], t, side="right") - 1]
        assert (seen.x - measured.x, seen.y - measured.y) == pytest.approx(y[:2], abs=1e-9)
    # The error model alone, in FMPy: the same outputs.
    alone = fmpy.simulate_fmu(
        str(path),
        stop_time=float(outputs["time"][-1]),
        output_interval=1.0,
        start_values={
            **{name: value.ravel().tolist() for name, value in ERROR_MODEL.items()},
            "u": ERROR_TARGET,
        },
    )
    np.testing.assert_allclose(outputs["y"], alone["y"], rtol=1e-12, atol=1e-12)
    # And it approaches its target as a first-order lag does: 1 - exp(-t / tau).
    t = outputs["time"][-1]
    expected = np.array(ERROR_TARGET) * (1 - np.exp(-t / TAU))
    np.testing.assert_allclose(outputs["y"][-1], expected, atol=2e-3)


# The search: Bouncing Ball's coefficient of restitution (its model description's range,
# 0.5 to 1) and drop height (a start value). The requirement: after the first bounce, the
# ball never rises above 0.8 m; balls dropped high enough and bouncy enough violate it.
REQUIREMENT = "always[1.0, 3.0] (h <= 0.8)"


def _bounce(fmu_path: Path, sample: dict[str, Any], fidelity: str) -> Any:
    return fmi.simulate(
        fmu_path,
        stop_time=3.0,
        parameters={"e": sample["e"]},
        start_values={"h": sample["h"]},
        placement=default_placement(check_fidelity(fidelity)),
    )


@pytest.mark.fidelity("low")
def test_a_search_over_an_fmus_parameters_finds_a_violation(reference_fmus: Path) -> None:
    path = reference_fmus / "fmi3" / "BouncingBall.fmu"
    model = fmi.describe(path)

    def simulate(sample: dict[str, Any], fidelity: str, seed: int) -> Any:
        return _bounce(path, sample, fidelity)

    result = falsify(
        simulate,
        REQUIREMENT,
        {"e": model.range("e"), "h": (0.5, 1.5)},
        optimizer="lhs",
        budget=30,
        seed=1,
        levels=("low", "medium"),  # found in-process, confirmed with the FMU as a process
    )
    assert result.falsified, result.summary()
    found = result.counterexample
    assert found is not None
    # The ball rises to about e**2 * h after its first bounce: only a high, bouncy one can.
    assert found.example["e"] ** 2 * found.example["h"] > 0.8
    assert result.transfer_rates == {"medium": 1.0}
