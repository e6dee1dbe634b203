"""The local simulators (lockstep on one simulated clock) and their running simulations."""

from __future__ import annotations

import logging
import math
import os
from pathlib import Path
from typing import Any, Generic, TypeVar, overload

import msgspec

from ..core.clock import Scheduler
from ..core.errors import ConfigurationError, MulticosimError
from ..core.interfaces import (
    Component,
    Node,
    NodeId,
    RunsImages,
    StartsSeveral,
    new_simulator_token,
)
from .environment import LocalEnvironment
from .rundirs import new_run_dir, remove_tree
from .simulation import NodeSet, started
from .waits import DEFAULT_STEP_TIMEOUT, check_timeout

__all__ = [
    "LocalSimulatorBase",
    "ProcessSimulation",
    "ProcessSimulator",
    "SelfContainedSimulation",
    "SelfContainedSimulator",
    "config_json",
]

NodeT = TypeVar("NodeT", bound=Node)

log = logging.getLogger(__name__)

# Slower pacing than a thousandth of real time is a mistake, not a setting: a run would
# look hung.
MIN_REALTIME = 1e-3


class ProcessSimulation(NodeSet):
    """A running ProcessSimulator: nodes, the simulated clock, the run directory."""

    def __init__(self, owner: int, environment: LocalEnvironment, keep_run_dir: bool) -> None:
        super().__init__(owner, "the simulation")
        self.environment = environment
        self._keep_run_dir = keep_run_dir

    @property
    def time(self) -> float:
        """Current simulated time in seconds."""
        return self.environment.scheduler.time

    @property
    def seed(self) -> int:
        """The simulation seed."""
        return self.environment.seed

    @property
    def scheduler(self) -> Scheduler:
        """The simulated clock its components step on."""
        return self.environment.scheduler

    @property
    def run_dir(self) -> Path:
        """Where component logs are written."""
        return self.environment.run_dir

    def advance(self, duration: float) -> None:
        """Run every participant for ``duration`` simulated seconds (the host drives)."""
        from ..core.clock import to_ns

        scheduler = self.environment.scheduler
        with scheduler.lock():
            scheduler.advance(to_ns(duration, field="duration"))

    def logs(self) -> dict[str, Path]:
        """Log files of the components that run as processes, by component name.

        If the run directory was removed under the running simulation, the logs of its
        processes are written again from their open files first.
        """
        for handle in self.environment.processes.values():
            handle.restore_log()
        return {p.stem: p for p in sorted(self.environment.run_dir.glob("*.log"))}

    def stop(self) -> None:
        """Stop every node in reverse start order, then release the clock and sockets."""
        if self.stopped:
            return
        self.environment.scheduler.closed = True
        super().stop()

    def release(self) -> None:
        """Release the clock and sockets, and remove the run directory unless it is kept
        (the last cleanup of a stop)."""
        self.environment.close()
        run_dir = self.environment.run_dir
        if not run_dir.exists():
            # Not an error of the run (its processes kept their files open and ran on), but
            # its logs are gone, and a sweep could not have found it had this host died.
            log.warning("the run directory %s was removed while the simulation ran", run_dir)
        elif not self._keep_run_dir:
            remove_tree(run_dir)


EnvT = TypeVar("EnvT", bound=LocalEnvironment)


class LocalSimulatorBase(Generic[EnvT]):
    """What the lockstep simulators share: validated settings, ``add``, starting in order."""

    runs_images = False
    """Whether its environment runs containers (components that need images)."""

    def __init__(
        self,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | os.PathLike[str] | None = None,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ConfigurationError("seed", seed, "a non-negative integer")
        if realtime is not None and (
            isinstance(realtime, bool)
            or not isinstance(realtime, int | float)
            or not MIN_REALTIME <= realtime < math.inf
        ):
            raise ConfigurationError(
                "realtime", realtime, f"None or a finite speed factor >= {MIN_REALTIME:g}"
            )
        check_timeout("step_timeout", step_timeout)
        self.seed = seed
        self.realtime = realtime
        self.step_timeout = step_timeout
        self.run_dir = Path(run_dir) if run_dir is not None else None
        self._token = new_simulator_token()
        self._components: list[tuple[NodeId[Any], Any]] = []
        self._names: set[str] = set()
        self._started = False

    @overload
    def add(
        self, component: Component[EnvT, NodeT], *, before: NodeId[Any] | None = None
    ) -> NodeId[NodeT]: ...
    @overload
    def add(
        self, component: Component[None, NodeT], *, before: NodeId[Any] | None = None
    ) -> NodeId[NodeT]: ...
    def add(self, component: Any, *, before: NodeId[Any] | None = None) -> NodeId[Any]:
        """Add ``component``; components start, and step within an instant, in add order.

        ``before`` places it ahead of an already added component instead of last (a scenario
        keeps its firmware last, so an injector added later still steps before it).
        """
        position = len(self._components)
        if before is not None:
            before.check_owner(self._token)
            ids = [nid for nid, _ in self._components]
            if before not in ids:
                raise ConfigurationError("before", before, "the id of a component added here")
            position = ids.index(before)
        if self._started:
            raise MulticosimError("components cannot be added after start()")
        if not callable(getattr(component, "start", None)):
            raise ConfigurationError("component", component, "an object with start(environment)")
        if required_images(component) and not self.runs_images:
            raise ConfigurationError(
                "component",
                component,
                "a component that runs no container (containers run on a simulator of the "
                "'docker' placement)",
            )
        name = str(getattr(component, "name", None) or type(component).__name__)
        names = {name, *(component.node_names() if isinstance(component, StartsSeveral) else ())}
        for taken in sorted(names & self._names):
            raise ConfigurationError("name", taken, "a name not used by another component")
        self._names.update(names)
        node_id: NodeId[Any] = NodeId(self._token, len(self._components), name)
        self._components.insert(position, (node_id, component))
        return node_id

    def replace(self, node_id: NodeId[NodeT], component: Component[EnvT, NodeT]) -> None:
        """Swap the component ``node_id`` names for ``component`` before start (same place, id).

        For scenarios that reconfigure a component they added (a remapped sensor topic).
        """
        if self._started:
            raise MulticosimError("components cannot be replaced after start()")
        node_id.check_owner(self._token)
        for i, (nid, _) in enumerate(self._components):
            if nid == node_id:
                self._components[i] = (nid, component)
                return
        raise ConfigurationError("node_id", node_id, "the id of a component added here")

    def start(self) -> ProcessSimulation:
        """Start every component in add order; on failure stop those started, then raise."""
        raise NotImplementedError  # each simulator makes its own environment

    def _new_run(self) -> tuple[str, Path]:
        """Mark the simulator started; make the run's id and directory."""
        if self._started:
            raise MulticosimError(
                "this simulator was already started; create a new simulator for another run"
            )
        self._started = True
        return new_run_dir(self.run_dir)

    def _start_components(self, simulation: ProcessSimulation, environment: EnvT) -> None:
        """Start every component in add order; on failure stop those started, then raise."""
        try:
            for node_id, component in self._components:
                simulation._add_node(node_id, _start_component(component, environment))
        except BaseException as exc:
            try:
                simulation.stop()
            except BaseExceptionGroup as group:
                exc.add_note(f"stopping the partial simulation also failed: {group!r}")
            raise


class ProcessSimulator(LocalSimulatorBase[LocalEnvironment]):
    """The local backend: components in-process or as local processes, in lockstep.

    ``seed`` fixes every random source; ``realtime`` paces simulated time to wall time
    (None: as fast as possible); ``run_dir`` keeps logs there instead of a temporary folder;
    ``step_timeout`` is how long (wall-clock seconds) a process participant may take for one
    step before the run fails with NodeTimeoutError naming it.
    """

    def start(self) -> ProcessSimulation:
        """Start every component in add order; on failure stop those started, then raise."""
        run_id, run_dir = self._new_run()
        environment = LocalEnvironment(
            run_id=run_id,
            run_dir=run_dir,
            seed=self.seed,
            scheduler=Scheduler(realtime=self.realtime),
            step_timeout=self.step_timeout,
        )
        simulation = ProcessSimulation(self._token, environment, self.run_dir is not None)
        simulation.add_cleanup("the clock and sockets", simulation.release)
        started(simulation)
        self._start_components(simulation, environment)
        return simulation


def _start_component(component: Any, environment: LocalEnvironment) -> Node:
    # Components written for no environment (``Component[None, N]``, like the paper's F16
    # example) declare it with ``environment: None``; they get None.
    if _wants_no_environment(component):
        node: Node = component.start(None)
    else:
        node = component.start(environment)
    if not isinstance(node, Node):
        raise ConfigurationError("component", component, "start() returning a node with stop()")
    return node


def _wants_no_environment(component: Any) -> bool:
    import inspect

    try:
        hints = inspect.get_annotations(type(component).start, eval_str=True)
    except Exception:
        return False
    hint = hints.get("environment", inspect.Parameter.empty)
    return hint is None or hint is type(None)


class SelfContainedSimulation(NodeSet):
    """A running SelfContainedSimulator."""


class SelfContainedSimulator:
    """A simulator of self-contained components (``Component[None, N]``), in this process.

    Its components need no environment: no clock, coordinator or seed (in-process
    participants and firmware need a clock: they run on a ``ProcessSimulator``).
    """

    def __init__(self) -> None:
        self._token = new_simulator_token()
        self._components: list[tuple[NodeId[Any], Component[None, Any]]] = []
        self._started = False

    def add(self, component: Component[None, NodeT]) -> NodeId[NodeT]:
        """Add ``component``; it is started with ``start(None)``."""
        name = str(getattr(component, "name", None) or type(component).__name__)
        node_id: NodeId[NodeT] = NodeId(self._token, len(self._components), name)
        self._components.append((node_id, component))
        return node_id

    def start(self) -> SelfContainedSimulation:
        """Start every component in add order."""
        if self._started:
            raise MulticosimError(
                "this simulator was already started; create a new simulator for another run"
            )
        self._started = True
        simulation = SelfContainedSimulation(self._token, "the in-process simulation")
        try:
            for node_id, component in self._components:
                simulation._add_node(node_id, component.start(None))
        except BaseException:
            simulation.stop()
            raise
        return simulation


def config_json(config: object) -> str:
    """A configuration object as JSON, for passing to a component process on its command line."""
    return msgspec.json.encode(config).decode()


def participant_command(factory: str, config: object) -> list[str]:
    """The command line (after ``python -m``) of participant ``factory`` given ``config``.

    The same in a process and in the runtime image, which has ``multicosim`` on its path.
    A factory that takes no configuration gets None (no ``--config``).
    """
    command = ["multicosim", "participant", factory]
    return command if config is None else [*command, "--config", config_json(config)]


def required_images(component: object) -> list[str]:
    """The images ``component`` runs (empty for one that runs no container)."""
    return list(component.required_images()) if isinstance(component, RunsImages) else []
