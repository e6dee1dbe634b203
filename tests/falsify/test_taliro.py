"""psy-taliro 3.x: the paper's appendix example, each sample one simulation."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest
from falsify_cart import PIT, run

import multicosim as mcs
import multicosim.search.taliro as mtaliro
from multicosim.search.requirements import load_rtamt
from multicosim.trace import read_trace

load_rtamt()  # quiets rtamt's import-time DeprecationWarning before staliro imports it
import staliro  # noqa: E402
import staliro.optimizers  # noqa: E402
import staliro.specifications.rtamt  # noqa: E402


def cart(static: Mapping[str, float], fidelity: str, seed: int) -> dict[str, list[float]]:
    return run((static["speed"], round(static["steps"])), fidelity, seed)


def test_uniform_random_finds_the_pit_and_saves_the_trace(tmp_path: Path) -> None:
    result = mtaliro.falsify(
        cart,
        PIT,
        static_inputs={"speed": (0.0, 5.0), "steps": (1, 100)},
        iterations=200,
        seed=0,
        trace_dir=tmp_path,
    )
    assert result.falsified
    assert result.evaluations == 48  # UniformRandom stops at the first falsifying sample
    assert result.robustness == pytest.approx(-0.01)
    speed, steps = result.sample["speed"], round(result.sample["steps"])
    assert abs(speed * (steps - 1) * 0.05 - 3.7) < 0.1
    assert result.evaluation.worst_time > 0
    mcap_path, layout_path, png_path = result.traces
    assert layout_path.name == "trace.layout.json"
    assert png_path.suffix == ".png"
    trace = read_trace(mcap_path)
    assert trace.info["search"] == "psy-taliro"
    assert float(trace.info["robustness"]) == pytest.approx(result.robustness)


def test_the_papers_appendix_with_staliro_objects() -> None:
    """The appendix as written, on psy-taliro 3.x, with the rover standing in for PX4.

    ``Gazebo(backend=ODE(iterations=...), step_size=...)`` becomes the MuJoCo
    ``WorldConfig(iterations=..., timestep=...)``; the waypoint becomes the rover's mission.
    """
    from multicosim.physics import WorldConfig
    from multicosim.rover import Mission, Rover

    def simulate(static: Mapping[str, float], fidelity: str, seed: int) -> object:
        world = WorldConfig(iterations=round(static["iters"]), timestep=static["step_size"])
        simulation = Rover(fidelity=fidelity, seed=seed, world=world).start()  # type: ignore[arg-type]
        try:
            trajectory = simulation.controller.send(
                Mission(speed=static["speed"], distance=static["distance"])
            )
        finally:
            simulation.stop()
        # The paper's signal is "alt": the rover's height.
        return {"time": trajectory.times, "alt": [s.z for s in trajectory.samples]}

    mymodel = mtaliro.model(simulate, fidelity="low")
    spec = staliro.specifications.rtamt.parse_dense("always alt > 0.0")
    opt: Any = staliro.optimizers.UniformRandom()
    options = staliro.TestOptions(
        static_inputs={
            "iters": (1, 100),
            "step_size": (0.001, 0.01),
            "speed": (1.0, 10.0),
            "distance": (0.0, 20.0),
        },
        iterations=5,
        seed=1,
    )
    runs = staliro.test(mymodel, spec, opt, options)
    costs = [e.cost for e in runs[0].evaluations]
    assert len(costs) == 5
    assert all(c == pytest.approx(0.25) for c in costs)  # the rover never leaves the ground


def test_bad_static_inputs() -> None:
    with pytest.raises(mcs.ConfigurationError, match="static_inputs"):
        mtaliro.falsify(cart, PIT, static_inputs={})
    with pytest.raises(mcs.ConfigurationError, match=r"static_inputs\['speed'\]"):
        mtaliro.falsify(cart, PIT, static_inputs={"speed": (5.0, 1.0)})
    with pytest.raises(mcs.ConfigurationError, match="fidelity"):
        mtaliro.model(cart, fidelity="ultra")


def test_a_simulate_function_of_another_shape_is_refused_before_anything_runs() -> None:
    def two_arguments(static: Mapping[str, float], fidelity: str) -> object:
        raise AssertionError("must not run")

    with pytest.raises(mcs.ConfigurationError, match=r"simulate\(sample, fidelity, seed\)"):
        mtaliro.falsify(two_arguments, PIT, static_inputs={"speed": (0.0, 5.0)})  # type: ignore[arg-type]
