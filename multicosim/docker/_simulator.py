"""ContainerSimulator: one Docker network per simulation, components as containers."""

from __future__ import annotations

import contextlib
import logging
from typing import Any, TypeVar

from ..core.clock import Scheduler
from ..core.errors import MulticosimError
from ..core.interfaces import Composite, Node
from ..local.rundirs import remove_tree
from ..local.simulators import LocalSimulatorBase, ProcessSimulation, required_images
from .engine import LABEL_RUN, APIError, NotFound, client, labels, require_image
from .environment import ContainerEnvironment
from .node import ContainerNode

__all__ = ["ContainerSimulation", "ContainerSimulator"]

NodeT = TypeVar("NodeT", bound=Node)

log = logging.getLogger(__name__)


class ContainerSimulation(ProcessSimulation):
    """A running ContainerSimulator: its nodes, network, simulated clock and run directory."""

    environment: ContainerEnvironment

    @property
    def network(self) -> str:
        """The name of the simulation's Docker network."""
        return self.environment.network

    @property
    def run_id(self) -> str:
        """The id every container and the network of this run are labelled with."""
        return self.environment.run_id

    def containers(self) -> list[ContainerNode]:
        """The container nodes of this simulation, in start order."""
        found: list[ContainerNode] = []
        for node in self.nodes:
            _collect(node, found)
        return found

    def stop(self) -> None:
        """Stop every node in reverse start order, remove the network; idempotent."""
        if self.stopped:
            return
        # Ask every container to exit at once; each node's stop then only waits and removes.
        # Best effort: whatever fails here, the nodes' own stops below still run.
        try:
            for container in reversed(self.containers()):
                container._signal_stop()
        except Exception as exc:
            log.debug("signalling the containers to stop failed: %s", exc)
        super().stop()


class ContainerSimulator(LocalSimulatorBase[ContainerEnvironment]):
    """The Docker backend: a network per simulation, each component a container on it.

    Containers join the lockstep through a coordinator listening on the network's gateway
    address; ``seed`` and ``realtime`` mean what they mean for ProcessSimulator. In-process
    components (InProcessComponent, InProcessFirmwareComponent) may be mixed in.
    ``run_dir`` keeps each container's output there (NAME.log) after the run.
    """

    runs_images = True

    def start(self) -> ContainerSimulation:
        """Create the network, start every component in add order; on failure undo it all."""
        docker_client = client()
        api = docker_client.api
        # Check every image first: a missing one fails before anything is created.
        for node_id, component in self._components:
            for image in required_images(component):
                require_image(api, image, node_id.name)

        run_id, run_dir = self._new_run()
        try:
            network = api.create_network(run_id, driver="bridge", labels=labels(run_id))
        except APIError as exc:
            remove_tree(run_dir)
            raise MulticosimError(
                f"could not create the simulation's network: {exc.explanation or exc}; if "
                "Docker's address pools are exhausted, `multicosim sweep` "
                "removes networks left by killed runs (`docker network prune` removes all)"
            ) from exc
        try:
            config = api.inspect_network(network["Id"])["IPAM"]["Config"]
            gateway = next(c["Gateway"] for c in config if c.get("Gateway"))
            environment = ContainerEnvironment(
                run_id=run_id,
                run_dir=run_dir,
                seed=self.seed,
                scheduler=Scheduler(realtime=self.realtime),
                client=docker_client,
                network=run_id,
                gateway=gateway.split("/")[0],
                keep_logs=self.run_dir is not None,
                step_timeout=self.step_timeout,
            )
        except BaseException:
            api.remove_network(network["Id"])
            raise
        simulation = ContainerSimulation(self._token, environment, self.run_dir is not None)
        # Cleanups run last-registered first: sockets close before the network goes.
        simulation.add_cleanup("the network", lambda: _remove_network(api, run_id))
        simulation.add_cleanup("the clock and sockets", simulation.release)
        self._start_components(simulation, environment)
        return simulation


def _collect(node: object, found: list[ContainerNode]) -> None:
    # A node is a container, or is made of nodes (a firmware node, an attached stack, real
    # firmware with its bridges) some of which are containers.
    if isinstance(node, ContainerNode):
        found.append(node)
    elif isinstance(node, Composite):
        for part in node.parts():
            _collect(part, found)


def _remove_network(api: Any, run_id: str) -> None:
    from .node import _remove_container

    # A container whose stop failed would keep the network busy: remove whatever of this run
    # is left first, so that the network (an address pool slot) is always given back.
    for leftover in api.containers(all=True, filters={"label": f"{LABEL_RUN}={run_id}"}):
        _remove_container(api, leftover["Id"])
    with contextlib.suppress(NotFound):
        api.remove_network(run_id)
