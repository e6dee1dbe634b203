"""The ``ray`` placement: each participant and firmware a Ray actor's program on a cluster.

The simulation's clock, its coordinator and the in-process parts (a ground station, a
trace recorder) stay in this process, which must itself be a driver on a node of the
cluster; each participant and firmware gets an actor
([`ComponentHost`][multicosim.ray.host.ComponentHost]) on the node Ray places it on, which runs the
same program a local process would (``python -m multicosim participant ...``, ``... serve ...``)
with the same environment, so that a seed gives the same run here as on the ``process`` placement.
Ray spreads the actors over the nodes unless told otherwise (``strategy``, or per component
``options``).

External programs (SITL builds, ``program(spec)``) are not run on Ray nodes: use the
``process`` or ``docker`` placement for real firmware.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NoReturn

from ..core.errors import ConfigurationError, NodeStartError, NodeTimeoutError
from ..core.wire import Hello
from ..local import LocalEnvironment, participant_command
from ..local.waits import DEFAULT_STEP_TIMEOUT, check_timeout
from ..placement import Endpoint, FirmwareProgram, ParticipantProgram, ProgramSpec
from .cluster import ENV_ADDRESS, check_address, connect
from .host import HOST_PLACEHOLDER, ComponentHost
from .node import RayFirmwareNode, RayNode, RemoteProgram
from .simulator import RayEnvironment, RaySimulator

__all__ = ["ACTOR_OPTIONS", "Ray", "RayFirmware", "RayParticipant"]

ACTOR_OPTIONS = (
    "accelerator_type",
    "label_selector",
    "memory",
    "num_cpus",
    "num_gpus",
    "resources",
    "runtime_env",
    "scheduling_strategy",
)
"""The Ray actor options a component's entry in ``Ray(options=...)`` may set."""

STRATEGIES = ("SPREAD", "DEFAULT")

STOP_TIMEOUT = 5.0
"""How long (s) a program has to exit after SIGTERM before it is killed."""

_PING_TIMEOUT = 5.0  # how long a started firmware may take to answer across nodes


def _ray_environment(environment: LocalEnvironment, name: str) -> RayEnvironment:
    if not isinstance(environment, RayEnvironment):
        raise ConfigurationError(
            "placement",
            "ray",
            f"a simulator of the ray placement for {name!r} (its coordinator must listen "
            "where the cluster's nodes reach it); this simulator runs none",
        )
    return environment


def _driver_path() -> list[str]:
    """This process's own import path (without the interpreter's): a program on a node
    imports the user's modules as this process does, where the node has them."""
    prefixes = {
        Path(p).resolve()
        for p in (sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix)
    }
    given = os.environ.get("PYTHONPATH", "")
    entries = [p for p in given.split(os.pathsep) if p]
    for entry in sys.path:
        path = Path(entry or os.getcwd()).resolve()
        if any(path.is_relative_to(p) for p in prefixes) or not path.is_dir():
            continue
        if str(path) not in entries:
            entries.append(str(path))
    return entries


def _tcp(host: str, port: int) -> str:
    return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"


def launch(
    environment: RayEnvironment,
    placement: Ray,
    name: str,
    args: list[str],
    *,
    start_timeout: float,
    stop_timeout: float = STOP_TIMEOUT,
) -> tuple[RayNode, Hello]:
    """Start ``python -m ARGS`` as component ``name`` on a node of the cluster; return once it
    has joined the simulation (its actor and program are stopped if it does not)."""
    options = placement.actor_options(name)
    ray = environment.ray
    order = environment.next_order()
    try:
        actor = ray.remote(ComponentHost).options(**options).remote(name)
    except (TypeError, ValueError) as exc:
        raise ConfigurationError(
            f"options[{name!r}]", options, f"Ray actor options: {exc}"
        ) from exc
    handle = RemoteProgram(name, actor, ray, environment.run_dir / f"{name}.log")
    try:
        handle.start(args, environment.component_env(name), _driver_path(), placement.place_timeout)
    except BaseException:
        handle.terminate(stop_timeout)
        raise
    environment.processes[name] = handle
    node = RayNode(handle, stop_timeout, environment)
    environment.coordinator.expect(name, order, handle)
    try:
        hello = environment.coordinator.wait_ready(name, start_timeout)
    except BaseException:
        environment.coordinator.forget(name)
        handle.terminate(stop_timeout)
        raise
    return node, hello


class RayParticipant:
    """Participant ``program`` as the program of a Ray actor (``multicosim participant``)."""

    def __init__(self, program: ParticipantProgram, placement: Ray) -> None:
        self.program = program
        self.placement = placement
        self.name = program.name

    def start(self, environment: LocalEnvironment) -> RayNode:
        """Place its actor, start its program there; return once it has joined."""
        program = self.program
        node, _ = launch(
            _ray_environment(environment, program.name),
            self.placement,
            program.name,
            participant_command(program.factory, program.config),
            start_timeout=program.start_timeout,
        )
        return node


class RayFirmware:
    """Firmware ``program`` served by a Ray actor's program, reached at its node's address."""

    def __init__(self, program: FirmwareProgram, placement: Ray) -> None:
        self.program = program
        self.placement = placement
        self.name = program.name

    def start(self, environment: LocalEnvironment) -> RayFirmwareNode[Any, Any]:
        """Place its actor, serve the firmware there on a free port; return once it has joined
        the simulation and answers from this process."""
        program = self.program
        ray_env = _ray_environment(environment, program.name)
        args = ["multicosim", "serve", program.factory, "--host", HOST_PLACEHOLDER, "--port", "0"]
        node, hello = launch(
            ray_env, self.placement, program.name, args, start_timeout=program.start_timeout
        )
        if not hello.port:
            node.stop()
            raise NodeStartError(program.name, "joined the simulation without a firmware port")
        endpoint = _tcp(node.node_ip, hello.port)
        firmware: RayFirmwareNode[Any, Any] = RayFirmwareNode(
            node,
            endpoint,
            ray_env,
            msgtype=program.msgtype,
            replytype=program.replytype,
            timeout=program.timeout,
        )
        try:
            firmware.ping(timeout=min(program.start_timeout, _PING_TIMEOUT))
        except BaseException as exc:
            tail = node.log_tail()
            firmware.stop()
            if isinstance(exc, NodeTimeoutError):
                raise NodeStartError(
                    program.name,
                    f"joined the simulation but does not answer at {endpoint} (can this "
                    "machine reach that node's address?)",
                    log_tail=tail,
                ) from exc
            raise
        return firmware


def _check_options(options: object) -> dict[str, dict[str, Any]]:
    allowed = f"a mapping of component names to Ray actor options ({', '.join(ACTOR_OPTIONS)})"
    if not isinstance(options, Mapping):
        raise ConfigurationError("options", options, allowed)
    checked: dict[str, dict[str, Any]] = {}
    for name, given in options.items():
        if not isinstance(name, str) or not isinstance(given, Mapping):
            raise ConfigurationError("options", options, allowed)
        for key in given:
            if key not in ACTOR_OPTIONS:
                raise ConfigurationError(
                    f"options[{name!r}]", key, f"one of {', '.join(ACTOR_OPTIONS)}"
                )
        checked[name] = dict(given)
    return checked


class Ray:
    """Components as Ray actors on the nodes of a cluster, in lockstep with this process.

    ``address`` is the cluster to join: ``HOST:PORT`` of its head node, ``"auto"`` (one
    started with ``ray start`` on this machine), ``"local"`` (start a local one), or None:
    ``MCS_RAY_ADDRESS`` if set, else a running cluster, else a new local one. This process
    joins it as a driver on first use and stays connected (a connection made before is
    used as it is). Each component's actor asks for ``num_cpus`` CPUs and is placed by
    ``strategy`` (``"SPREAD"``: over the nodes; ``"DEFAULT"``: Ray's packing);
    ``options`` sets Ray actor options per component name, e.g. ``{"world": {"resources":
    {"big": 1}}}`` to put the world on the node started with that resource. An actor waits
    up to ``place_timeout`` seconds for a node with room for it:

    ```python
    rover.Rover(fidelity="medium", placement=Ray("10.0.0.5:6379"))
    ```
    """

    name = "ray"
    in_process = False

    def __init__(
        self,
        address: str | None = None,
        *,
        num_cpus: float = 1.0,
        strategy: str = "SPREAD",
        options: Mapping[str, Mapping[str, Any]] | None = None,
        place_timeout: float = 60.0,
    ) -> None:
        field = "address"
        if address is None and os.environ.get(ENV_ADDRESS, "").strip():
            address, field = os.environ[ENV_ADDRESS], ENV_ADDRESS
        self.address = check_address(address, field)
        if (
            isinstance(num_cpus, bool)
            or not isinstance(num_cpus, int | float)
            or not math.isfinite(num_cpus)
            or num_cpus < 0
        ):
            raise ConfigurationError("num_cpus", num_cpus, "a finite number of CPUs >= 0")
        if strategy not in STRATEGIES:
            raise ConfigurationError(
                "strategy",
                strategy,
                f"one of {', '.join(map(repr, STRATEGIES))} (others per component, in options)",
            )
        check_timeout("place_timeout", place_timeout)
        self.num_cpus = float(num_cpus)
        self.strategy = strategy
        self.options = _check_options({} if options is None else options)
        self.place_timeout = float(place_timeout)

    def actor_options(self, name: str) -> dict[str, Any]:
        """The Ray options of component ``name``'s actor (never restarted: a restarted
        program could not rejoin the lockstep)."""
        return {
            "num_cpus": self.num_cpus,
            "scheduling_strategy": self.strategy,
            **self.options.get(name, {}),
            "max_restarts": 0,
            "max_task_retries": 0,
            "max_concurrency": 1,
        }

    def simulator(
        self,
        *,
        seed: int = 0,
        realtime: float | None = None,
        run_dir: str | None = None,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> RaySimulator:
        """A RaySimulator joining this placement's cluster when it starts."""
        return RaySimulator(
            self.address, seed=seed, realtime=realtime, run_dir=run_dir, step_timeout=step_timeout
        )

    def participant(self, program: ParticipantProgram) -> RayParticipant:
        """The participant as a Ray actor's program on a node."""
        return RayParticipant(program, self)

    def firmware(self, program: FirmwareProgram) -> RayFirmware:
        """The firmware served by a Ray actor's program, reached at its node's address."""
        return RayFirmware(program, self)

    def program(self, spec: ProgramSpec) -> NoReturn:
        """Not supported: an external program (a SITL build) runs on the ``process`` or
        ``docker`` placement (ConfigurationError)."""
        raise ConfigurationError(
            "placement",
            self.name,
            f"a placement that runs external programs such as {spec.name!r} ('process' on "
            "this machine, 'docker' in a container); 'ray' runs participants and firmware",
        )

    def endpoint(self, environment: LocalEnvironment) -> Endpoint:
        """This process's address on the cluster (loopback outside a Ray simulation)."""
        host = environment.address if isinstance(environment, RayEnvironment) else "127.0.0.1"
        return Endpoint(host=host, private=False)

    def prepare(self) -> None:
        """Join the cluster (PlacementUnavailableError where Ray is not installed or no
        cluster can be joined)."""
        connect(self.address)

    def __repr__(self) -> str:
        return f"<placement 'ray' at {self.address or 'the default address'}>"
