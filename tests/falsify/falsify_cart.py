"""A small falsification scenario on the test cart (multicosim.testing), at three fidelities.

The cart drives at ``speed`` for ``steps`` firmware periods (0.05 s each), then comes to
rest. Requirement: it never comes to rest in the pit between 3.6 m and 3.8 m::

    always ((v > 0.01) or (abs(x - 3.7) >= 0.1))

Fidelity levels (a stand-in for real model detail, exercising the execution environments):

* low: the cart and its driver in-process, ideal position sensor;
* medium: the driver firmware behind ZeroMQ in a thread, position noise 0.01 m;
* high: the cart and the driver as separate processes, the cart integrated 5x finer.
"""

from __future__ import annotations

from typing import Any

import multicosim as mcs
from multicosim.search.strategies import FreshSimulations
from multicosim.testing import Cart, CartState, Drive, DriveReport, Speed, drive
from multicosim.trace import TraceOptions

PIT = "always ((v > 0.01) or (abs(x - 3.7) >= 0.1))"
PERIOD = 0.05  # the drive firmware's period
REST_STEPS = 20


class CartRun:
    """A running cart scenario: ``drive(speed, steps)`` returns the trajectory columns."""

    def __init__(self, simulation: Any, driver: mcs.NodeId[Any], fidelity: str) -> None:
        self.simulation = simulation
        self.fidelity = fidelity
        self._driver = driver

    def drive(self, speed: float, steps: int) -> dict[str, list[float]]:
        """Drive, then rest; return columns time, x, v (commanded speed)."""
        node = self.simulation.get(self._driver)
        moving: DriveReport = node.send(Drive(speed=speed, steps=steps))
        resting: DriveReport = node.send(Drive(speed=0.0, steps=REST_STEPS))
        # A handler's first step is the instant the previous one ended: keep one sample.
        rest = [i for i, t in enumerate(resting.times) if not moving.times or t > moving.times[-1]]
        return {
            "time": [*moving.times, *(resting.times[i] for i in rest)],
            "x": [*moving.positions, *(resting.positions[i] for i in rest)],
            "v": [speed] * len(moving.times) + [0.0] * len(rest),
        }

    def trace_options(self) -> TraceOptions:
        """Topic types (for messages from processes) and the pit as the 'plan'."""
        return TraceOptions(types={"state": CartState, "cmd": Speed})

    def stop(self) -> None:
        """Stop the simulation."""
        self.simulation.stop()


class CartScenario:
    """The cart scenario as a simulator: ``CartScenario(fidelity, seed).start()``."""

    def __init__(self, fidelity: str = "low", seed: int = 0) -> None:
        self.fidelity = fidelity
        self.simulator = mcs.ProcessSimulator(seed=seed)
        if fidelity == "high":
            self.simulator.add(
                mcs.ProcessComponent(
                    "python -m multicosim participant multicosim.testing:Cart --config 0.002",
                    name="cart",
                )
            )
            self.driver: mcs.NodeId[Any] = self.simulator.add(
                mcs.ProcessFirmwareComponent(
                    "python -m multicosim serve multicosim.testing:drive --port {port}",
                    msgtype=Drive,
                    replytype=DriveReport,
                    name="drive",
                )
            )
        elif fidelity == "medium":
            self.simulator.add(mcs.InProcessComponent(lambda: Cart(noise=0.01), name="cart"))
            self.driver = self.simulator.add(
                mcs.ThreadFirmwareComponent(drive, replytype=DriveReport)
            )
        else:
            self.simulator.add(mcs.InProcessComponent(Cart, name="cart"))
            self.driver = self.simulator.add(mcs.InProcessFirmwareComponent(drive))

    def start(self) -> CartRun:
        """Start the cart and its driver."""
        return CartRun(self.simulator.start(), self.driver, self.fidelity)


def run(example: Any, fidelity: str, seed: int = 0) -> dict[str, list[float]]:
    """One simulation of ``(speed, steps)`` (or ``{"speed": .., "steps": ..}``) at ``fidelity``:
    the trajectory columns."""
    speed, steps = (example["speed"], example["steps"]) if isinstance(example, dict) else example
    with FreshSimulations(fidelity=fidelity, seed=seed)(CartScenario) as cart:
        return cart.drive(speed, steps)  # type: ignore[no-any-return]
