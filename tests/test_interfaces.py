"""The paper's interfaces with self-contained in-process components."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

import multicosim as mcs


@dataclass
class Gcas:
    """An analytic model as a CommunicationNode (the paper's F16 example, simplified)."""

    gain: float
    log: list[str]
    stopped: int = 0

    def send(self, msg: float) -> list[float]:
        return [msg * self.gain**k for k in range(4)]

    def stop(self) -> None:
        self.stopped += 1
        self.log.append(f"stop gcas {self.gain}")


@dataclass(frozen=True)
class GcasComponent:
    """``Component[None, Gcas]``: needs no environment."""

    gain: float = 0.5
    name: str = "gcas"
    log: list[str] = field(default_factory=list)

    def start(self, environment: None) -> Gcas:
        self.log.append(f"start {self.name}")
        return Gcas(self.gain, self.log)


@dataclass
class Failing:
    name: str
    log: list[str]

    def stop(self) -> None:
        self.log.append(f"stop {self.name}")
        raise RuntimeError(f"{self.name} failed to stop")


@dataclass(frozen=True)
class FailingComponent:
    name: str
    log: list[str]

    def start(self, environment: None) -> Failing:
        return Failing(self.name, self.log)


def test_component_started_directly_like_the_paper() -> None:
    node = GcasComponent(gain=2.0).start(None)
    assert node.send(1.0) == [1.0, 2.0, 4.0, 8.0]
    assert isinstance(node, mcs.CommunicationNode)


def test_in_process_simulator_runs_component_none() -> None:
    log: list[str] = []
    simulator = mcs.SelfContainedSimulator()
    node_id = simulator.add(GcasComponent(gain=0.5, log=log))
    with simulator.start() as simulation:
        node = simulation.get(node_id)
        assert node.send(8.0) == [8.0, 4.0, 2.0, 1.0]
    assert node.stopped == 1
    simulation.stop()  # idempotent
    assert node.stopped == 1


def test_process_simulator_accepts_component_none() -> None:
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(GcasComponent(gain=3.0))
    with simulator.start() as simulation:
        assert simulation.get(node_id).send(1.0)[1] == 3.0


def test_stop_is_reverse_order_and_reports_every_failure() -> None:
    log: list[str] = []
    simulator = mcs.SelfContainedSimulator()
    simulator.add(FailingComponent("first", log))
    simulator.add(GcasComponent(log=log, name="middle"))
    simulator.add(FailingComponent("last", log))
    simulation = simulator.start()
    with pytest.raises(ExceptionGroup) as info:
        simulation.stop()
    assert log[-3:] == ["stop last", "stop gcas 0.5", "stop first"]
    messages = sorted(str(e) for e in info.value.exceptions)
    assert messages == ["first failed to stop", "last failed to stop"]
    notes = [n for e in info.value.exceptions for n in getattr(e, "__notes__", [])]
    assert "while stopping component 'first'" in notes
    simulation.stop()  # a second stop does nothing and raises nothing
    assert log.count("stop first") == 1


def test_get_with_a_node_id_from_another_simulator() -> None:
    a, b = mcs.SelfContainedSimulator(), mcs.SelfContainedSimulator()
    a.add(GcasComponent())
    foreign = b.add(GcasComponent())
    with a.start() as simulation, pytest.raises(mcs.ConfigurationError, match="node_id"):
        simulation.get(foreign)


def test_starting_a_simulator_twice_is_an_error() -> None:
    simulator = mcs.SelfContainedSimulator()
    simulator.add(GcasComponent())
    with simulator.start(), pytest.raises(mcs.MulticosimError, match="already started"):
        simulator.start()


def test_node_id_equality_and_repr() -> None:
    simulator = mcs.SelfContainedSimulator()
    first = simulator.add(GcasComponent(name="one"))
    second = simulator.add(GcasComponent(name="two"))
    assert first != second
    assert first == first
    assert len({first, second, first}) == 2
    assert "one" in repr(first)
