"""The lockstep scheduler: order, same-instant routing, no lost messages, determinism."""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import pytest

import multicosim as mcs
from multicosim import testing
from multicosim.core.clock import Scheduler, to_ns


class Tick(mcs.Message):
    n: int


@dataclass
class Source:
    """Publishes an increasing counter on ``ticks`` every period."""

    period: float = 0.01
    n: int = 0

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        self.n += 1
        ctx.publish("ticks", Tick(n=self.n))


@dataclass
class Relay:
    """Forwards ``ticks`` to ``relayed`` with ten added (an injector-like participant)."""

    period: float = 0.01

    def setup(self, ctx: mcs.StepContext) -> None:
        self.sub = ctx.subscribe("ticks", Tick)

    def step(self, ctx: mcs.StepContext) -> None:
        for msg in self.sub.messages:
            ctx.publish("relayed", Tick(n=msg.n + 10))


@dataclass
class Sink:
    """Records what it receives, with the simulated time of the step."""

    period: float = 0.05
    topic: str = "ticks"
    seen: list[tuple[float, int]] = field(default_factory=list)

    def setup(self, ctx: mcs.StepContext) -> None:
        self.sub = ctx.subscribe(self.topic, Tick)

    def step(self, ctx: mcs.StepContext) -> None:
        self.seen.extend((ctx.time, m.n) for m in self.sub.messages)


def _same(participant: mcs.Participant) -> mcs.Participant:
    return participant


def _run(*participants: mcs.Participant, duration: float, seed: int = 0) -> mcs.ProcessSimulation:
    simulator = mcs.ProcessSimulator(seed=seed)
    for i, p in enumerate(participants):
        simulator.add(mcs.InProcessComponent(functools.partial(_same, p), name=f"p{i}"))
    simulation = simulator.start()
    try:
        simulation.advance(duration)
    except BaseException:
        simulation.stop()
        raise
    return simulation


def test_slow_subscriber_gets_every_message_in_order() -> None:
    sink = Sink(period=0.05)
    with _run(Source(period=0.01), sink, duration=0.2) as simulation:
        # The source publishes at t = 0.00..0.19; the sink steps every 50 ms (at 0.00, 0.05,
        # 0.10, 0.15) and sees each batch whole; what came after 0.15 waits for its step at 0.20.
        assert [n for _, n in sink.seen] == list(range(1, 17))
        assert sink.seen[0] == (0.0, 1)
        assert sink.seen[5] == (0.05, 6)
        assert simulation.time == pytest.approx(0.2)


def test_later_participant_sees_same_instant_messages() -> None:
    sink = Sink(period=0.01, topic="relayed")
    with _run(Source(), Relay(), sink, duration=0.04):
        # Source, relay and sink step in add order at each instant: no added delay.
        assert sink.seen == [(0.0, 11), (0.01, 12), (0.02, 13), (0.03, 14)]


def test_earlier_participant_sees_messages_at_its_next_step() -> None:
    sink = Sink(period=0.01)
    with _run(sink, Source(), duration=0.03):
        assert sink.seen == [(0.01, 1), (0.02, 2)]


def test_periods_are_exact_integers() -> None:
    assert to_ns(0.1) * 3 == to_ns(0.3)
    sink = Sink(period=0.1)
    with _run(Source(period=0.1), sink, duration=10.0):
        assert len(sink.seen) == 100
        assert sink.seen[-1] == (9.9, 100)


def test_firmware_drives_the_clock_and_it_stops_between_calls() -> None:
    simulator = mcs.ProcessSimulator()
    cart = simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    driver = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    with simulator.start() as simulation:
        report = simulation.get(driver).send(testing.Drive(speed=2.0, steps=4))
        assert report.times == [0.0, 0.05, 0.1, 0.15]
        # The cart moves from t=0.01 on, after the first command at t=0.
        assert report.positions == pytest.approx([0.0, 0.1, 0.2, 0.3])
        frozen_at = simulation.time
        time.sleep(0.05)
        assert simulation.time == frozen_at
        x = simulation.get(cart).participant.x
        report = simulation.get(driver).send(testing.Drive(speed=0.0, steps=2))
        # A handler starting later first sees the latest state (latched), then continues.
        assert report.times == [frozen_at, frozen_at + 0.05]
        assert report.positions[0] == pytest.approx(x)


def test_same_seed_same_noise_other_seed_other_noise() -> None:
    def noises(seed: int) -> list[float]:
        sink_cart = testing.Cart(noise=0.5)
        simulator = mcs.ProcessSimulator(seed=seed)
        simulator.add(mcs.InProcessComponent(lambda: sink_cart, name="cart"))
        driver = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
        with simulator.start() as simulation:
            report = simulation.get(driver).send(testing.Drive(speed=1.0, steps=5))
        return report.positions

    assert noises(1) == noises(1)
    assert noises(1) != noises(2)


def test_realtime_paces_simulated_time() -> None:
    simulator = mcs.ProcessSimulator(realtime=4.0)
    simulator.add(mcs.InProcessComponent(Source, name="source"))
    with simulator.start() as simulation:
        start = time.monotonic()
        simulation.advance(0.4)
        # 0.4 simulated seconds at 4x real time take at least 0.1 s of wall time.
        assert time.monotonic() - start >= 0.09


def test_bad_realtime_and_period() -> None:
    with pytest.raises(mcs.ConfigurationError, match="realtime"):
        mcs.ProcessSimulator(realtime=0)
    with pytest.raises(mcs.ConfigurationError, match="realtime"):
        Scheduler(realtime=-1.0)
    with pytest.raises(mcs.ConfigurationError, match="period"):
        to_ns(0.0)


def test_subscribing_with_two_types_is_an_error() -> None:
    ctx = mcs.StepContext("x", 0)
    ctx.subscribe("t", Tick)
    assert ctx.subscribe("t", Tick) is ctx.subscribe("t", Tick)
    with pytest.raises(mcs.MessageTypeError, match="subscribed as"):
        ctx.subscribe("t", testing.Speed)


def test_wrong_payload_on_a_topic_names_topic_and_type() -> None:
    @dataclass
    class WrongSource(Source):
        def step(self, ctx: mcs.StepContext) -> None:
            ctx.publish("ticks", testing.Speed(speed=1.0))

    sink = Sink(period=0.01)
    with pytest.raises(mcs.TransportError, match="topic 'ticks' is not a valid Tick"):
        _run(WrongSource(), sink, duration=0.02).stop()


def test_firmware_without_clock_cannot_step() -> None:
    ctx = mcs.FirmwareContext("lonely", 0, 10, None)
    with pytest.raises(mcs.MulticosimError, match="without a simulation clock"):
        ctx.step()


@mcs.firmware(msgtype=testing.Echo)
def _clock_reader(msg: testing.Echo, ctx: mcs.FirmwareContext) -> float:
    return ctx.time


def test_a_handler_starts_at_the_current_simulated_time() -> None:
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    inproc = simulator.add(mcs.InProcessFirmwareComponent(_clock_reader))
    threaded = simulator.add(mcs.ThreadFirmwareComponent(_clock_reader, name="threaded"))
    with simulator.start() as simulation:
        simulation.advance(0.25)
        assert simulation.get(inproc).send(testing.Echo(text="")) == pytest.approx(0.25)
        assert simulation.get(threaded).send(testing.Echo(text="")) == pytest.approx(0.25)
