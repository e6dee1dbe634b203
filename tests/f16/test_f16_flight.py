"""The F-16 flies AeroBench's flight, the same in every placement; its trace; the requirement.

AeroBench's own ``run_f16_sim`` is the oracle: the participant steps its loop on the
simulated clock and must give its trajectory bit for bit.
"""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import multicosim as mcs
import multicosim.f16 as f16
from multicosim import trace
from multicosim.f16 import arch
from multicosim.search.requirements import Requirement

# The ARCH-COMP worst corner (the deepest dive the inputs allow) and the middle of the ranges.
CORNER = {"roll": 0.2833 * math.pi, "pitch": -0.4 * math.pi, "yaw": -0.25 * math.pi}
MIDDLE = {"roll": 0.24 * math.pi, "pitch": -0.375 * math.pi, "yaw": -0.25 * math.pi}
# Searches and verdicts fly in this process: a flight is the same bits in every placement
# (test_every_placement_flies_the_same_flight), and this costs no process per flight.
HERE = "in-process"
# Past the lowest point of every dive (about 6 s): what the placement tests fly.
SHORT = 8.0
# AeroBench's state vector, by our names.
AEROBENCH_ORDER = (
    *("airspeed", "alpha", "beta", "roll", "pitch", "yaw", "roll_rate", "pitch_rate"),
    *("yaw_rate", "north", "east", "altitude", "power"),
)


def _run_f16_sim(aerobench: f16.AeroBench) -> Any:
    """AeroBench's own loop and GCAS autopilot, imported as its examples import them."""
    if str(aerobench.code) not in sys.path:
        sys.path.insert(0, str(aerobench.code))
    run = importlib.import_module("aerobench.run_f16_sim")
    gcas = importlib.import_module("aerobench.examples.gcas.gcas_autopilot")
    return run.run_f16_sim, gcas.GcasAutopilot


@pytest.mark.parametrize("fidelity", ["low", "medium", "high"])
def test_the_flight_is_aerobench_run_f16_sim_bit_for_bit(
    aerobench: f16.AeroBench, fidelity: str
) -> None:
    initial = arch.Benchmark(aerobench, altitude=2330.0).initial(CORNER)
    flight = f16.F16(
        fidelity,  # type: ignore[arg-type]
        placement="in-process",
        aerobench=aerobench,
        initial=initial,
        duration=SHORT,
    ).fly()
    run_f16_sim, gcas = _run_f16_sim(aerobench)
    knobs = f16.FIDELITY_KNOBS[fidelity]  # type: ignore[index]
    expected = run_f16_sim(
        initial.vector(),
        SHORT,
        gcas(init_mode="roll", gain_str="old"),
        step=knobs.step,
        model_str=knobs.model,
        integrator_str=knobs.integrator,
    )
    assert flight.times == list(expected["times"])
    assert [s.mode for s in flight] == expected["modes"]
    ours = np.array([[getattr(s, name) for name in AEROBENCH_ORDER] for s in flight])
    assert np.array_equal(ours, expected["states"][:, :13])
    assert flight.fidelity == fidelity
    # The GCAS rolls the wings level, pulls up, and stands by once the nose is up.
    assert [mode for _, mode in flight.modes()] == ["roll", "pull", "standby"]


@pytest.mark.parametrize("placement", ["process", "docker"])
def test_every_placement_flies_the_same_flight(
    aerobench: f16.AeroBench, placement: str, request: pytest.FixtureRequest, nothing_left: None
) -> None:
    if placement == "docker":
        from pytest_multicosim.docker import require_docker, runtime_image

        require_docker()
        runtime_image(request.config)
    initial = arch.Benchmark(aerobench).initial(MIDDLE)
    flights = [
        f16.F16(
            "medium", placement=where, seed=7, aerobench=aerobench, initial=initial, duration=SHORT
        ).fly()
        for where in ("in-process", placement)
    ]
    assert len(flights[0]) == round(SHORT * 30) + 1
    assert flights[1] == flights[0]


def test_a_falsifying_dive_violates_and_a_nominal_one_holds(aerobench: f16.AeroBench) -> None:
    requirement = Requirement(arch.REQUIREMENT)
    # ARCH-COMP's instance from its middle: the GCAS recovers with room to spare.
    nominal = requirement.evaluate(arch.Benchmark(aerobench, placement=HERE)(MIDDLE, "medium", 0))
    # The deepest dive from 2330 ft: the recovery bottoms out below the ground.
    low = arch.Benchmark(aerobench, altitude=2330.0, placement=HERE)(CORNER, "medium", 0)
    crash = requirement.evaluate(low)
    assert nominal.robustness > 1000.0
    assert -20.0 < crash.robustness < 0.0
    assert crash.robustness == pytest.approx(low.lowest.altitude)
    assert crash.worst_time == pytest.approx(low.lowest.time)
    # A GCAS left in standby engages only below its 1000 ft floor: too late, from 4040 ft.
    standby = f16.F16(
        "low",
        aerobench=aerobench,
        initial=arch.Benchmark(aerobench).initial(MIDDLE),
        gcas_mode="standby",
    ).fly()
    assert requirement.evaluate(standby).robustness < -1000.0


def test_its_signals_are_in_the_trace(aerobench: f16.AeroBench, tmp_path: Path) -> None:
    scenario = f16.F16("low", aerobench=aerobench, duration=1.0)
    with scenario.start() as simulation, trace.Recorder().attach(simulation) as recorder:
        flight = simulation.fly()
    path = recorder.save(tmp_path / "f16.mcap", seed=0, fidelity="low")
    data = trace.read_trace(path)
    states = data.topic(f16.STATE_TOPIC)
    assert [m.data["altitude"] for m in states] == flight.altitude
    assert data.channels[f16.STATE_TOPIC].schema_name.endswith("F16State")
    poses = data.topic(trace.POSE_CHANNEL)
    assert len(poses) == len(flight)
    # Wings level northwards: the pose is in ENU metres, the nose towards north (+y).
    pose = poses[0].data["pose"]
    assert pose["position"]["z"] == pytest.approx(4040 * 0.3048)
    q = pose["orientation"]
    assert (q["w"], q["z"]) == (pytest.approx(math.sqrt(0.5)), pytest.approx(math.sqrt(0.5)))
    assert len(data.topic(f"{trace.PATH_CHANNEL}/truth")) == len(flight)


def test_falsification_finds_a_crash_within_its_budget(aerobench: f16.AeroBench) -> None:
    # From 2330 ft only the deepest dives end in the ground (about 3 % of the inputs at
    # medium fidelity): searched at low, each violation confirmed at medium.
    benchmark = arch.Benchmark(aerobench, altitude=2330.0, placement=HERE)
    result = benchmark.falsify(levels=("low", "medium"), budget=30, optimizer="tpe", seed=0)
    counterexample = result.counterexample
    assert counterexample is not None, result.summary()
    assert result.first_confirmed is not None
    assert result.first_confirmed <= 30
    assert counterexample.failing_levels == ("low", "medium")
    assert counterexample.results["medium"].evaluation.robustness < 0


def test_the_aircraft_publishes_its_state_every_step_of_the_clock(
    aerobench: f16.AeroBench,
) -> None:
    class Monitor:  # another participant, reading the F-16's topic at the same rate
        period = 1 / 30

        def setup(self, ctx: mcs.StepContext) -> None:
            self.state = ctx.subscribe(f16.STATE_TOPIC, f16.F16State)
            self.seen: list[tuple[float, float]] = []

        def step(self, ctx: mcs.StepContext) -> None:
            for state in self.state.messages:
                self.seen.append((ctx.time, state.time))

    monitor = Monitor()
    config = f16.F16Config(directory=str(aerobench.code), duration=1.0)
    simulator = mcs.ProcessSimulator()
    aircraft = simulator.add(f16.Aircraft(config, name="jet"))
    simulator.add(mcs.InProcessComponent(lambda: monitor, name="monitor"))
    with simulator.start() as simulation:
        simulation.advance(2.0)
        flight = simulation.get(aircraft).flight()
    # One state per step, seen in the instant it is published; none after the duration.
    assert len(flight) == len(monitor.seen) == 31
    assert all(abs(now - stamped) < 1e-6 for now, stamped in monitor.seen)
    assert flight.final.time == pytest.approx(1.0)
    assert flight.samples[0].altitude == 4040.0  # InitialState()'s, level at ARCH-COMP's altitude
