"""The base of the scenario simulators (PX4, rover, ArduPilot, FMU loops) and their simulations.

A [`Scenario`][multicosim.placement.scenario.Scenario] owns what every scenario has: its fidelity,
its placement and the simulator that placement makes, the seed, adding components (an injector, a
monitor) in the right place, and starting. A scenario class keeps only what is its own: which
components it adds and what its simulation offers.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, Self, TypeVar

from ..core.errors import MulticosimError
from ..core.fidelity import Fidelity, check_fidelity
from ..core.interfaces import Component, Node, NodeId
from ..local.simulation import started
from ..local.simulators import ProcessSimulation
from .registry import resolve

if TYPE_CHECKING:
    from ..core.clock import Scheduler
    from ..local import LocalSimulatorBase
    from .protocol import Placement

__all__ = ["Scenario", "ScenarioSimulation"]

NodeT = TypeVar("NodeT", bound=Node)
SimulationT = TypeVar("SimulationT")


class ScenarioSimulation:
    """Base of scenario simulations (rover, PX4): a running simulation with named nodes.

    Scenarios add their own attributes (``controller``, ``firmware``, ``world``); the rest
    (clock, seed, lookup, logs, stopping) is the wrapped simulation's.
    """

    def __init__(self, simulation: ProcessSimulation) -> None:
        self.simulation = simulation
        started(self)

    @property
    def time(self) -> float:
        """Current simulated time (s)."""
        return self.simulation.time

    @property
    def seed(self) -> int:
        """The simulation's seed."""
        return self.simulation.seed

    @property
    def scheduler(self) -> Scheduler:
        """The simulated clock every component of this simulation steps on."""
        return self.simulation.scheduler

    @property
    def run_dir(self) -> Path:
        """Where the components' logs (and real firmware's working directories) are."""
        return self.simulation.run_dir

    def get(self, node_id: NodeId[NodeT]) -> NodeT:
        """The node ``node_id`` names (ids come from the scenario simulator's ``add``)."""
        return self.simulation.get(node_id)

    def advance(self, duration: float) -> None:
        """Run the world for ``duration`` simulated seconds without a mission."""
        self.simulation.advance(duration)

    def logs(self) -> dict[str, Path]:
        """Log files of the components that run as processes or containers."""
        return self.simulation.logs()

    def stop(self) -> None:
        """Stop every node; idempotent."""
        self.simulation.stop()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class Scenario(Generic[SimulationT]):
    """Base of the scenario simulators: a fidelity, a placement, its simulator, ``add``.

    ``placement`` is a registered name (``"in-process"``, ``"process"``, ``"docker"``, ...),
    a [`Placement`][multicosim.placement.Placement], or None for the fidelity's default (this
    process at low fidelity, local processes above). ``seed`` fixes every random source;
    ``realtime`` paces simulated time to wall time (None: as fast as possible); ``run_dir``
    keeps the components' logs there.
    """

    def __init__(
        self,
        *,
        fidelity: Fidelity,
        placement: str | Placement | None = None,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | None = None,
    ) -> None:
        self.fidelity: Fidelity = check_fidelity(fidelity)
        self.placement: Placement = resolve(placement, self.fidelity)
        self.seed = seed
        self._simulator: LocalSimulatorBase[Any] = self.placement.simulator(
            seed=seed, realtime=realtime, run_dir=run_dir
        )
        self._anchor: NodeId[Any] | None = None

    def _add_own(self, component: Component[Any, NodeT], *, anchor: bool = False) -> NodeId[NodeT]:
        """Add one of the scenario's own components; ``anchor``: the one ``add`` goes before."""
        node_id: NodeId[NodeT] = self._simulator.add(component)
        if anchor:
            self._anchor = node_id
        return node_id

    def add(self, component: Component[Any, NodeT]) -> NodeId[NodeT]:
        """Add a component (an injector, a monitor) before the scenario's firmware, so that
        what it publishes reaches the firmware in the same instant.

        A component that runs a container needs the ``docker`` placement.
        """
        try:
            return self._simulator.add(component, before=self._anchor)
        except MulticosimError as exc:
            exc.add_note(f"the scenario's placement is {self.placement.name!r}")
            raise

    def replace(self, node_id: NodeId[NodeT], component: Component[Any, NodeT]) -> None:
        """Swap the component ``node_id`` names for ``component`` (before start)."""
        self._simulator.replace(node_id, component)

    def _start_simulation(self) -> ProcessSimulation:
        """Start every component in add order (the scenario wraps what it returns)."""
        simulation: ProcessSimulation = self._simulator.start()
        return simulation

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(fidelity={self.fidelity!r}, "
            f"placement={self.placement.name!r}, seed={self.seed})"
        )
