"""A vehicle multicosim does not ship, in its world: the cart-pole of ``cartpole.py``.

Nothing of multicosim is changed for it: the module beside this test is all a user writes
(the documentation shows it). At medium fidelity its MuJoCo world and its controller run as
separate processes in lockstep; a trace records them; an injector between them corrupts the
pole's angle sensor.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from statistics import fmean

import cartpole
import msgspec
import pytest

import multicosim as mcs
import multicosim.attacks as attacks
from multicosim.local import participant_command
from multicosim.physics import WorldConfig
from multicosim.testing import check_component
from multicosim.trace import Recorder, read_trace

pytest.importorskip("mujoco")

HERE = Path(__file__).parent
MISSION = cartpole.Balance(target=0.5, duration=8.0)
SETTLED = 5.0  # s: the pole stands and the cart rests at its target well before this
RAW = "cartpole/state/raw"  # where the world publishes the encoders under attack
TYPES = {cartpole.STATE: cartpole.State, RAW: cartpole.State, cartpole.PUSH: cartpole.Push}
# What a run gave: the controller's reply and every message routed.
Run = tuple[cartpole.State, Recorder]


@pytest.fixture(autouse=True, scope="module")
def importable() -> Iterator[None]:
    """Component processes import cartpole from this directory."""
    with pytest.MonkeyPatch.context() as monkeypatch:
        path = os.pathsep.join(p for p in (str(HERE), os.environ.get("PYTHONPATH")) if p)
        monkeypatch.setenv("PYTHONPATH", path)
        yield


def world_component(config: WorldConfig | None = None) -> mcs.ProcessComponent:
    """The cart-pole's MuJoCo world as a process."""
    command = participant_command("cartpole:world", config or WorldConfig())
    return mcs.ProcessComponent(["python", "-m", *command], name="world")


def run(seed: int, models: Sequence[attacks.Model] | None = None) -> Run:
    """World and controller processes (and an injector process on the encoders when
    ``models`` is given) in lockstep, recorded."""
    simulator = mcs.ProcessSimulator(seed=seed)
    if models is None:
        simulator.add(world_component())
    else:
        simulator.add(world_component(WorldConfig(sensor_topics={"state": RAW})))
        config = attacks.InjectorConfig(
            vehicle="cartpole",
            sensor="state",
            source=RAW,
            target=cartpole.STATE,
            period=cartpole.PERIOD,
            models=tuple(models),
        )
        simulator.add(attacks.InjectorComponent(config, placement="process"))
    node_id = simulator.add(
        mcs.ProcessFirmwareComponent(
            "python -m multicosim serve cartpole:balance --port {port}",
            msgtype=cartpole.Balance,
            replytype=cartpole.State,
            name="controller",
        )
    )
    recorder = Recorder(types=TYPES)
    with simulator.start() as simulation:
        recorder.attach(simulation)
        reply = simulation.get(node_id).send(MISSION)
    return reply, recorder


@pytest.fixture(scope="module")
def honest(mcs_seed: int) -> Run:
    """The run without an attack (deterministic, so the tests share it)."""
    return run(mcs_seed)


def routed(recorder: Recorder, *topics: str) -> list[tuple[str, int, bytes]]:
    """(topic, time in ns, MessagePack bytes) of what was routed on ``topics``, in order."""
    return [(d.topic, d.time_ns, d.data) for d in recorder.deliveries if d.topic in topics]


def states(recorder: Recorder, topic: str = cartpole.STATE) -> list[tuple[float, cartpole.State]]:
    """The encoders' readings on ``topic``, with their times (s)."""
    return [
        (t / 1e9, msgspec.msgpack.decode(data, type=cartpole.State))
        for _, t, data in routed(recorder, topic)
    ]


def at_rest(recorder: Recorder, topic: str = cartpole.STATE) -> list[cartpole.State]:
    """The readings on ``topic`` from SETTLED on."""
    return [s for t, s in states(recorder, topic) if t >= SETTLED]


# -- in one process: the world starts from the state the vehicle set ------------------------


def test_the_first_reading_is_of_the_state_the_vehicle_set() -> None:
    simulator = mcs.ProcessSimulator()
    ideal = WorldConfig(noise=0.0)
    simulator.add(mcs.InProcessComponent(lambda: cartpole.world(ideal), name="world"))
    with simulator.start() as simulation, Recorder().attach(simulation) as recorder:
        simulation.advance(0.1)
    readings = [(d.time_ns, d.obj) for d in recorder.deliveries if d.topic == cartpole.STATE]
    assert readings[0] == (0, cartpole.State(x=0.0, v=0.0, angle=cartpole.TILT, rate=0.0))
    last = readings[-1][1]
    assert isinstance(last, cartpole.State)
    assert last.angle > cartpole.TILT  # nobody pushes: it falls
    assert last.x < 0.0  # and its fall pushes the cart back


# -- at medium fidelity: world and controller processes in lockstep -------------------------


@pytest.mark.fidelity("medium")
def test_the_controller_balances_the_pole_and_brings_the_cart_to_its_target(
    honest: Run, mcs_seed: int, tmp_path: Path
) -> None:
    reply, recorder = honest
    read = states(recorder)
    assert read[0][1].angle == pytest.approx(cartpole.TILT, abs=0.005)  # 5.7 degrees at first
    assert max(abs(s.angle) for _, s in read) < cartpole.TILT + 0.005  # never further over
    rest = at_rest(recorder)
    assert max(abs(s.angle) for s in rest) < math.radians(0.5)  # then it stands
    assert fmean(s.x for s in rest) == pytest.approx(MISSION.target, abs=0.005)
    assert reply.x == pytest.approx(MISSION.target, abs=0.01)

    path = recorder.save(tmp_path / "cartpole.mcap", seed=mcs_seed)
    trace = read_trace(path)
    assert set(trace.channels) == {cartpole.STATE, cartpole.PUSH}
    for topic in (cartpole.STATE, cartpole.PUSH):
        channel = trace.channels[topic]
        tp = TYPES[topic]
        assert channel.schema_name.endswith(tp.__name__)
        assert set(channel.schema["properties"]) == set(tp.__struct_fields__)
    pushes = trace.topic(cartpole.PUSH)
    assert len(pushes) == round(MISSION.duration / cartpole.PERIOD)  # one each control period
    assert [m.data["angle"] for m in trace.topic(cartpole.STATE)] == [s.angle for _, s in read]
    assert trace.info["seed"] == str(mcs_seed)


@pytest.mark.fidelity("medium")
def test_the_same_seed_gives_the_same_run(honest: Run, mcs_seed: int) -> None:
    reply, recorder = honest
    again, recorded_again = run(mcs_seed)
    _, recorded_other = run(mcs_seed + 1)
    topics = (cartpole.STATE, cartpole.PUSH)
    assert routed(recorded_again, *topics) == routed(recorder, *topics)
    assert again == reply
    assert routed(recorded_other, *topics) != routed(recorder, *topics)  # the noise is seeded


@pytest.mark.fidelity("medium")
def test_an_angle_bias_moves_the_cart_where_physics_says(honest: Run, mcs_seed: int) -> None:
    bias = 0.02  # rad: the pole's encoder reads 1.1 degrees more than the truth
    _, recorder = run(mcs_seed, [attacks.Bias(offset=bias, on="angle")])
    # At rest the pole stands upright (anything else falls) and the motor pushes nothing
    # (the slider's damping would move the cart): the controller's feedback is zero at the
    # position x where k_x (x - target) + k_angle * bias = 0.
    kx, _, ka, _ = cartpole.GAINS
    shift = -ka / kx * bias  # -0.13 m
    rest = fmean(s.x for s in at_rest(recorder))
    assert rest == pytest.approx(MISSION.target + shift, abs=0.005)
    assert rest - fmean(s.x for s in at_rest(honest[1])) == pytest.approx(shift, abs=0.005)
    # In truth the pole stands upright; the controller reads it tilted by the bias.
    assert fmean(s.angle for s in at_rest(recorder, RAW)) == pytest.approx(0.0, abs=0.001)
    assert fmean(s.angle for s in at_rest(recorder)) == pytest.approx(bias, abs=0.001)


@pytest.mark.fidelity("medium")
def test_a_zero_attack_leaves_the_run_bit_for_bit_identical(honest: Run, mcs_seed: int) -> None:
    zero: list[attacks.Model] = [
        attacks.Bias(offset=0.0),
        attacks.Gaussian(std=0.0, on="rate"),
        attacks.Drift(std=0.0, on="x", start=1.0),
        attacks.Delay(delay=0.0),
    ]
    reply, recorder = honest
    attacked, recorded = run(mcs_seed, zero)
    assert attacked == reply
    topics = (cartpole.STATE, cartpole.PUSH)
    assert routed(recorded, *topics) == routed(recorder, *topics)
    # The injector passed every reading on, unchanged, in the instant the world published it.
    assert [m[1:] for m in routed(recorded, RAW)] == [
        m[1:] for m in routed(recorder, cartpole.STATE)
    ]


# -- the conformance checker on the user's components --------------------------------------


def test_check_component_passes_on_the_controller() -> None:
    report = check_component(
        cartpole.balance,
        message=cartpole.Balance(target=0.2, duration=1.0),
        beside=lambda: [mcs.InProcessComponent(lambda: cartpole.world(WorldConfig()), "world")],
    )
    assert report.passed, str(report)
    assert report.target == "cartpole:balance"


def test_check_component_passes_on_the_world() -> None:
    report = check_component("cartpole:world", config=WorldConfig(), duration=0.5)
    assert report.passed, str(report)
