"""Static checks of the public types; mypy reads this file in CI (it is not a test module)."""

from __future__ import annotations

from typing import assert_type

import multicosim as mcs
from multicosim import testing


class Model:
    def send(self, msg: float) -> list[float]:
        return [msg]

    def stop(self) -> None:
        pass


class ModelComponent:
    def start(self, environment: None) -> Model:
        return Model()


def check_node_id_is_typed() -> None:
    simulator = mcs.SelfContainedSimulator()
    node_id = simulator.add(ModelComponent())
    assert_type(node_id, mcs.NodeId[Model])
    simulation = simulator.start()
    node = simulation.get(node_id)
    assert_type(node, Model)
    assert_type(node.send(1.0), list[float])


def check_process_components_are_typed() -> None:
    simulator = mcs.ProcessSimulator(seed=3)
    fw = simulator.add(
        mcs.ProcessFirmwareComponent(
            "python -m multicosim serve multicosim.testing:drive --port {port}",
            msgtype=testing.Drive,
            replytype=testing.DriveReport,
        )
    )
    assert_type(fw, mcs.NodeId[mcs.ProcessFirmwareNode[testing.Drive, testing.DriveReport]])
    inproc = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    world = simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    with simulator.start() as simulation:
        report = simulation.get(fw).send(testing.Drive(speed=1.0, steps=2))
        assert_type(report, testing.DriveReport)
        assert_type(
            simulation.get(inproc).send(testing.Drive(speed=1.0, steps=2)), testing.DriveReport
        )
        assert_type(simulation.get(world).participant, testing.Cart)


def check_protocols() -> None:
    node: mcs.CommunicationNode[float, list[float]] = Model()
    component: mcs.Component[None, Model] = ModelComponent()
    simulator: mcs.Simulator[None] = mcs.SelfContainedSimulator()
    del node, component, simulator


def check_ardupilot_is_typed() -> None:
    import multicosim.ardupilot as ardupilot

    simulator = ardupilot.ArduCopter(fidelity="medium", firmware_dir="ardupilot-sitl")
    with simulator.start() as simulation:
        assert_type(simulation, ardupilot.ArduPilotSimulation)
        assert_type(simulation.home, ardupilot.Home)
        config = ardupilot.Configuration([ardupilot.Waypoint(47.4, 8.5, 10.0)])
        assert_type(simulation.firmware.send(config), ardupilot.MissionResult)
        assert_type(simulation.get(simulator.firmware_id), ardupilot.ArduPilotNode)
