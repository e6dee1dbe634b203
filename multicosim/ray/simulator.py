"""RaySimulator: the simulation's clock here, its components' programs on a Ray cluster.

The simulator joins the cluster when it starts; its coordinator listens on the address Ray
knows this process's node by, so that programs on every node of the cluster can join the
lockstep (and only the run's own components are admitted, by their secret tokens).
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

from ..core.clock import Scheduler
from ..core.interfaces import Composite
from ..local import LocalEnvironment, LocalSimulatorBase, ProcessSimulation
from ..local.simulation import started
from ..local.waits import DEFAULT_STEP_TIMEOUT
from .cluster import check_address, connect, driver_address
from .node import RayNode

__all__ = ["RayEnvironment", "RaySimulation", "RaySimulator"]


class RayEnvironment(LocalEnvironment):
    """What a RaySimulator hands its components: the clock, the coordinator (listening on
    ``address``, this process's node on the cluster) and the connected ``ray`` module."""

    def __init__(
        self,
        *,
        run_id: str,
        run_dir: Path,
        seed: int,
        scheduler: Scheduler,
        ray: ModuleType,
        address: str,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        super().__init__(
            run_id=run_id,
            run_dir=run_dir,
            seed=seed,
            scheduler=scheduler,
            coordinator_host=address,
            step_timeout=step_timeout,
        )
        self.ray = ray
        self.address = address


class RaySimulation(ProcessSimulation):
    """A running RaySimulator: its nodes, the simulated clock and the run directory."""

    environment: RayEnvironment

    def ray_nodes(self) -> list[RayNode]:
        """The components running on the cluster, in start order."""
        found: list[RayNode] = []
        for node in self.nodes:
            _collect(node, found)
        return found


def _collect(node: object, found: list[RayNode]) -> None:
    # A firmware's node holds its program's; other composites may hold several.
    if isinstance(node, RayNode):
        found.append(node)
    elif isinstance(node, Composite):
        for part in node.parts():
            _collect(part, found)


class RaySimulator(LocalSimulatorBase[RayEnvironment]):
    """The Ray backend: components as actors on a cluster, stepped in lockstep from here.

    ``address`` is the cluster to join when it starts (see [`Ray`][multicosim.ray.Ray];
    a connection this process has already is used as it is). ``seed``, ``realtime``,
    ``run_dir`` and ``step_timeout`` mean what they mean for ProcessSimulator; in-process
    components may be mixed in.
    """

    def __init__(
        self,
        address: str | None = None,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | None = None,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        super().__init__(seed=seed, realtime=realtime, run_dir=run_dir, step_timeout=step_timeout)
        self.address = check_address(address)

    def start(self) -> RaySimulation:
        """Join the cluster, then start every component in add order; on failure stop those
        started, then raise (PlacementUnavailableError where no cluster can be joined)."""
        ray = connect(self.address)
        address = driver_address(ray)
        run_id, run_dir = self._new_run()
        environment = RayEnvironment(
            run_id=run_id,
            run_dir=run_dir,
            seed=self.seed,
            scheduler=Scheduler(realtime=self.realtime),
            ray=ray,
            address=address,
            step_timeout=self.step_timeout,
        )
        simulation = RaySimulation(self._token, environment, self.run_dir is not None)
        simulation.add_cleanup("the clock and sockets", simulation.release)
        started(simulation)
        self._start_components(simulation, environment)
        return simulation
