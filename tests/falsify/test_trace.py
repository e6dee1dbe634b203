"""Traces: real MCAP files written, read back with the mcap reader, plotted."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from falsify_cart import PIT, CartScenario
from mcap.reader import make_reader
from mcap.writer import Writer

import multicosim as mcs
from multicosim.search.requirements import Requirement
from multicosim.search.strategies import FreshSimulations
from multicosim.testing import Cart
from multicosim.trace import (
    DIALECT,
    METADATA_NAME,
    Recorder,
    TestTrace,
    activate,
    location_fix,
    plot_command,
    pose_in_frame,
    read_trace,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def drive(cart: object, speed: float = 2.0, steps: int = 30) -> dict[str, list[float]]:
    return cart.drive(speed, steps)  # type: ignore[attr-defined, no-any-return]


def test_every_topic_is_recorded_with_schemas_from_the_message_types(tmp_path: Path) -> None:
    cart = CartScenario("low").start()
    try:
        recorder = Recorder().attach(cart)
        drive(cart)
    finally:
        cart.stop()
    path = recorder.save(tmp_path / "run.mcap", seed=0, fidelity="low", backend="process")

    # Read with the mcap reader itself, not only through read_trace.
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        topics = {c.topic: c for c in summary.channels.values()}
        schemas = {s.id: s for s in summary.schemas.values()}
        records = {m.name: m.metadata for m in reader.iter_metadata()}
    assert set(topics) == {"state", "cmd"}
    assert {topics[t].message_encoding for t in topics} == {"json"}
    assert schemas[topics["state"].schema_id].name == "multicosim.testing.CartState"
    assert schemas[topics["state"].schema_id].encoding == "jsonschema"
    meta = records[METADATA_NAME]
    assert (meta["seed"], meta["fidelity"], meta["backend"]) == ("0", "low", "process")
    assert '"mcap": "1.6.0"' in meta["versions"]

    trace = read_trace(path)
    counts = {t: trace.channels[t].count for t in trace.channels}
    assert sum(counts.values()) == len(recorder.deliveries)
    assert trace.channels["state"].schema["properties"]["x"] == {"type": ["number", "null"]}
    assert trace.channels["state"].schema["$schema"] == DIALECT
    states = trace.topic("state")
    assert [m.log_time for m in states] == sorted(m.log_time for m in states)
    # The cart ends where the driver saw it: 2 m/s for 30 periods of 0.05 s, one period late.
    assert states[-1].data["x"] == pytest.approx(2.0 * 29 * 0.05)


def test_messages_from_processes_are_decoded_and_typed_by_the_scenario(tmp_path: Path) -> None:
    # High fidelity runs the cart and its driver as processes: messages arrive as MessagePack.
    cart = CartScenario("high").start()
    try:
        typed = Recorder().attach(cart)  # types from the scenario's trace_options()
        untyped = Recorder().attach(cart.simulation)  # the bare simulation offers none
        drive(cart, steps=10)
    finally:
        cart.stop()
    assert typed.deliveries
    assert all(d.obj is None for d in typed.deliveries)
    typed_trace = read_trace(typed.save(tmp_path / "typed.mcap"))
    untyped_trace = read_trace(untyped.save(tmp_path / "untyped.mcap"))
    assert typed_trace.channels["state"].schema_name == "multicosim.testing.CartState"
    assert untyped_trace.channels["state"].schema_name == "multicosim.Any"
    assert typed_trace.topic("state")[-1].data == untyped_trace.topic("state")[-1].data


def test_foxglove_channels_from_converters(tmp_path: Path) -> None:
    home_lat = 47.0

    def fix(message: dict[str, float]) -> tuple[float, float, float]:
        return home_lat, 8.0 + message["x"] * 1e-5, 488.0

    cart = CartScenario("low").start()
    try:
        recorder = Recorder(
            converters=[
                location_fix("state", fix),
                pose_in_frame("state", lambda m: ((m["x"], 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))),
            ]
        ).attach(cart)
        drive(cart, steps=5)
    finally:
        cart.stop()
    trace = read_trace(recorder.save(tmp_path / "fox.mcap"))
    location = trace.channels["mcs/location"]
    pose = trace.channels["mcs/pose"]
    assert location.schema_name == "foxglove.LocationFix"
    assert pose.schema_name == "foxglove.PoseInFrame"
    assert location.count == pose.count == trace.channels["state"].count
    last_fix = trace.topic("mcs/location")[-1]
    assert last_fix.data["latitude"] == home_lat
    assert last_fix.data["timestamp"] == {
        "sec": last_fix.log_time // 10**9,
        "nsec": last_fix.log_time % 10**9,
    }
    assert trace.topic("mcs/pose")[-1].data["pose"]["orientation"] == {
        "x": 0.0,
        "y": 0.0,
        "z": 0.0,
        "w": 1.0,
    }


def test_the_same_seed_gives_the_same_trace(tmp_path: Path) -> None:
    paths = []
    for name in ("a", "b"):
        cart = CartScenario("medium", seed=7).start()  # noisy sensor, firmware over ZeroMQ
        try:
            recorder = Recorder().attach(cart)
            drive(cart, steps=10)
        finally:
            cart.stop()
        paths.append(recorder.save(tmp_path / f"{name}.mcap", seed=7))
    assert paths[0].read_bytes() == paths[1].read_bytes()


class Scalar:
    """Publishes a bare number (not an object): its channel wraps it as {"value": ...}."""

    period = 0.1

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        ctx.publish("level", ctx.time)


def test_non_object_messages_are_wrapped(tmp_path: Path) -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(Scalar, name="scalar"))
    simulation = simulator.start()
    try:
        recorder = Recorder().attach(simulation)
        simulation.advance(0.35)
    finally:
        simulation.stop()
    trace = read_trace(recorder.save(tmp_path / "scalar.mcap"))
    assert [m.data for m in trace.topic("level")] == [
        {"value": 0.0},
        {"value": 0.1},
        {"value": 0.2},
        {"value": 0.3},
    ]


def test_a_test_trace_keeps_the_last_example_and_the_evaluation(tmp_path: Path) -> None:
    fresh = FreshSimulations(fidelity="low")
    requirement = Requirement(PIT)
    session = TestTrace(metadata={"test": "test_x", "seed": 0})
    with activate(session):
        for speed in (1.0, 2.0):  # two Hypothesis-like examples
            with fresh(CartScenario) as cart:
                trajectory = drive(cart, speed=speed, steps=37)
            evaluation = requirement.evaluate(trajectory)
    assert fresh.started == 2
    assert len(session.recorders) == 1  # the first example's recording was dropped
    assert all(not r._scheduler for r in session.recorders)  # detached at the end
    written = session.save(tmp_path, failing_example={"speed": 2.0, "steps": 37})
    assert [p.name for p in written] == ["trace.mcap", "trace.layout.json", "trace.png"]
    assert written[2].read_bytes().startswith(PNG_MAGIC)
    trace = read_trace(written[0])
    assert {"state", "cmd", "mcs/trajectory", "mcs/robustness"} <= set(trace.channels)
    last = trace.topic("mcs/trajectory")[-1].data
    assert last["x"] == pytest.approx(trajectory["x"][-1])
    assert trace.info["failing_example"] == '{"speed":2.0,"steps":37}'
    assert float(trace.info["robustness"]) == pytest.approx(evaluation.robustness)
    assert float(trace.info["worst_time"]) == evaluation.worst_time
    assert trace.info["test"] == "test_x"


def test_plot_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cart = CartScenario("low").start()
    try:
        recorder = Recorder().attach(cart)
        trajectory = drive(cart)
    finally:
        cart.stop()
    recorder.add_trajectory(trajectory)
    recorder.add_plan([(0.0, 0.0), (3.0, 0.0)])
    recorder.add_evaluation(Requirement("always (x <= 2)").evaluate(trajectory))
    path = recorder.save(tmp_path / "run.mcap")
    assert plot_command(str(path), str(tmp_path / "out.png")) == 0
    assert (tmp_path / "out.png").read_bytes().startswith(PNG_MAGIC)
    assert capsys.readouterr().out.strip() == str(tmp_path / "out.png")

    (tmp_path / "bad.mcap").write_bytes(b"not an mcap file")
    assert plot_command(str(tmp_path / "bad.mcap")) == 1
    assert "not a readable MCAP trace" in capsys.readouterr().err
    assert not (tmp_path / "bad.png").exists()

    # A valid MCAP file that multicosim did not write: a clear error, no blank picture.
    with open(tmp_path / "foreign.mcap", "wb") as stream:
        writer: Any = Writer(stream)
        writer.start(profile="", library="another tool")
        schema = writer.register_schema("point", "jsonschema", b'{"type": "object"}')
        channel = writer.register_channel("/points", "json", schema)
        writer.add_message(channel, log_time=0, data=b'{"x": 1}', publish_time=0)
        writer.finish()
    assert plot_command(str(tmp_path / "foreign.mcap")) == 1
    assert "not a multicosim trace" in capsys.readouterr().err
    assert not (tmp_path / "foreign.png").exists()


def test_read_errors(tmp_path: Path) -> None:
    with pytest.raises(mcs.TraceError, match="could not read"):
        read_trace(tmp_path / "missing.mcap")
    (tmp_path / "bad.mcap").write_bytes(b"\x89MCAP0\r\n" + b"garbage")
    with pytest.raises(mcs.TraceError, match="not a readable MCAP trace"):
        read_trace(tmp_path / "bad.mcap")


def test_attach_needs_a_simulation_with_a_clock() -> None:
    with pytest.raises(mcs.ConfigurationError, match="simulated clock"):
        Recorder().attach(object())
    cart = CartScenario("low").start()
    try:
        recorder = Recorder().attach(cart)
        with pytest.raises(mcs.TraceError, match="already attached"):
            recorder.attach(cart)
        recorder.detach()
        recorder.detach()  # idempotent
        drive(cart, steps=3)
        assert recorder.deliveries == []
    finally:
        cart.stop()


def test_cart_participant_is_recorded_from_construction_on() -> None:
    # A recorder attached right after start sees the participant's first publication.
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(Cart, name="cart"))
    simulation = simulator.start()
    try:
        recorder = Recorder().attach(simulation)
        simulation.advance(0.05)
    finally:
        simulation.stop()
    assert [d.time_ns for d in recorder.deliveries] == [
        0,
        10_000_000,
        20_000_000,
        30_000_000,
        40_000_000,
    ]


def test_a_test_trace_that_does_not_record_still_carries_fidelity_and_seed(
    tmp_path: Path,
) -> None:
    fresh = FreshSimulations()
    session = TestTrace(metadata={"fidelity": "medium", "seed": 5}, record=False)
    with activate(session), fresh(CartScenario) as cart:
        assert (cart.fidelity, cart.simulation.seed) == ("medium", 5)
        Requirement(PIT).evaluate(drive(cart))
    assert session.recorders == []
    assert session.save(tmp_path) == []
