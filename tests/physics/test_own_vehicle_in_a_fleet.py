"""A vehicle of one's own beside a quadrotor in one world, its sensor attacked, all recorded.

The cart-pole of ``cartpole.py`` (unchanged) and the quadrotor share one MuJoCo model, each
under its name; the cart-pole's topics are moved back to the ones its controller reads, its
encoders through an injector.
"""

from __future__ import annotations

from pathlib import Path

import cartpole
import msgspec
import pytest

import multicosim as mcs
import multicosim.attacks as attacks
from multicosim.mavlink.hil import Truth
from multicosim.physics import Pose, World, WorldConfig
from multicosim.quadrotor import QuadrotorVehicle
from multicosim.trace import Recorder, read_trace

RAW = "cart/state/raw"
BIAS = 0.05  # rad on the pole's angle


def test_a_cartpole_and_a_quadrotor_share_a_world_with_an_attack_recorded(
    tmp_path: Path,
) -> None:
    config = WorldConfig(noise=0.0, sensor_topics={"cart/state": RAW, "cart/push": cartpole.PUSH})
    vehicles = {"cart": cartpole.CartPole(), "quad": (QuadrotorVehicle(), Pose(east=5.0))}
    simulator = mcs.ProcessSimulator(seed=3)
    world_id = simulator.add(mcs.InProcessComponent(lambda: World(config, vehicles), "world"))
    injector = attacks.InjectorConfig(
        vehicle="cartpole",
        sensor="state",
        source=RAW,
        target=cartpole.STATE,
        period=cartpole.PERIOD,
        models=(attacks.Bias(offset=BIAS, on="angle"),),
    )
    simulator.add(attacks.InjectorComponent(injector))
    controller = simulator.add(mcs.InProcessFirmwareComponent(cartpole.balance))
    types = {RAW: cartpole.State, cartpole.STATE: cartpole.State, "quad/truth": Truth}
    with simulator.start() as simulation, Recorder(types=types).attach(simulation) as recorder:
        world = simulation.get(world_id).participant
        assert world.topics["cart/state"] == RAW
        assert world.topics["quad/truth"] == "quad/truth"
        simulation.get(controller).send(cartpole.Balance(target=0.2, duration=2.0))
        path = recorder.save(tmp_path / "fleet.mcap")
    trace = read_trace(path)
    raw = {m.log_time: m.data for m in trace.topic(RAW)}
    read = {m.log_time: m.data for m in trace.topic(cartpole.STATE)}
    assert raw, "the cart-pole's encoders were not recorded"
    shared = sorted(set(raw) & set(read))
    assert len(shared) >= 50
    for t in shared:
        assert read[t]["angle"] == pytest.approx(raw[t]["angle"] + BIAS)
        assert read[t]["x"] == raw[t]["x"]
    quad = trace.topic("quad/truth")
    assert quad
    # The quadrotor stands where it was put, beside the cart, on the world's ground.
    assert quad[-1].data["east"] == pytest.approx(5.0, abs=1e-6)
    assert quad[-1].data["down"] == pytest.approx(0.0, abs=0.01)
    state = msgspec.convert(read[shared[-1]], cartpole.State)
    assert abs(state.angle) < 0.5
