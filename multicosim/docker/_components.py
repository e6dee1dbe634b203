"""The paper's container classes: ContainerNode, ContainerComponent, AttachedComponent,
ContainerFirmwareComponent, and the environment a ContainerSimulator gives them.

Every container runs with an init process (so it stops at once on SIGTERM), carries the run's
labels (so a sweep can remove it if its host dies) and is removed when its node stops. It runs
as a non-root user, without capabilities, within memory and process limits
(:class:`ContainerLimits`), on its simulation's network only.
Programs inside reach the host's lockstep coordinator at the network's gateway address; the
host reaches a firmware through its port published on a random loopback port.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import re
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Generic, Literal, Protocol, TypeVar

from ..core import wire
from ..core.clock import Scheduler
from ..core.errors import (
    ConfigurationError,
    NodeCrashedError,
    NodeStartError,
    NodeTimeoutError,
    translate,
)
from ..core.interfaces import Node
from ..core.messages import MsgT, ReplyT
from ..local.environment import LocalEnvironment
from ..local.firmware import ProcessFirmwareNode, check_types
from ..local.processes import split_command
from ..local.rundirs import start_time
from ..local.waits import (
    DEFAULT_SEND_TIMEOUT,
    DEFAULT_START_TIMEOUT,
    DEFAULT_STEP_TIMEOUT,
    check_timeout,
)
from .engine import LABEL_COMPONENT, APIError, NotFound, labels, require_image

__all__ = [
    "AttachedComponent",
    "AttachedNode",
    "ContainerComponent",
    "ContainerEnvironment",
    "ContainerFirmwareComponent",
    "ContainerFirmwareNode",
    "ContainerLimits",
    "ContainerNode",
]

log = logging.getLogger(__name__)

HostT = TypeVar("HostT", bound=Node)
HostT_co = TypeVar("HostT_co", bound=Node, covariant=True)

DEFAULT_STOP_TIMEOUT = 2.0
# How long a started firmware may take to answer through its published port once it has
# said hello (the port proxy is already up by then; this only catches a wrong bind address).
_PORT_CHECK_TIMEOUT = 5.0


class ContainerEnvironment(LocalEnvironment):
    """What a ContainerSimulator hands its components: the network, the clock, the coordinator.

    The coordinator listens on the network's gateway address (never on all interfaces), so
    containers on the network, and only they and the host, can join the lockstep.
    """

    def __init__(
        self,
        *,
        run_id: str,
        run_dir: Path,
        seed: int,
        scheduler: Scheduler,
        client: Any,
        network: str,
        gateway: str,
        keep_logs: bool = False,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        super().__init__(
            run_id=run_id,
            run_dir=run_dir,
            seed=seed,
            scheduler=scheduler,
            coordinator_host=gateway,
            step_timeout=step_timeout,
        )
        self.client = client
        self.network = network
        self.gateway = gateway
        self.keep_logs = keep_logs
        self.labels = labels(run_id)

    def container_name(self, name: str) -> str:
        """The Docker name of component ``name``'s container in this run."""
        return f"{self.run_id}-{re.sub(r'[^a-zA-Z0-9_.-]', '_', name)}"


class ContainerNode:
    """A component running in a container (the paper's ContainerNode).

    Built from a running ``docker`` SDK container; ``stop`` stops and removes it. It is also
    the liveness watch of the component: ``poll`` gives its exit code once it has exited.
    """

    def __init__(
        self,
        container: Any,
        *,
        name: str | None = None,
        stop_timeout: float = DEFAULT_STOP_TIMEOUT,
        environment: LocalEnvironment | None = None,
        log_dir: Path | None = None,
    ) -> None:
        self.container = container
        self.id: str = container.id
        self.name: str = name or container.name
        self.stop_timeout = stop_timeout
        self.ports: dict[str, int] = {}
        self._api = container.client.api
        self._environment = environment
        self._log_dir = log_dir
        self._exit_code: int | None = None
        self._last_logs = ""
        self._stopped = False
        self._early: int | None = None
        self._signalled = False
        self._pid_stat: tuple[int, str] | None = None
        self._checked = 0.0

    def _watch_pid(self, pid: int) -> None:
        # Waits check liveness every 100 ms; an engine API call for each would cost more than
        # a firmware round trip. A local engine's containers are host processes: watch the
        # init process's /proc entry (with its start time, so a recycled pid is not mistaken).
        if pid > 0 and _engine_is_local():
            start = start_time(pid)
            if start is not None:
                self._pid_stat = (pid, start)

    def poll(self) -> int | None:
        """The container's exit code once it has exited, else None."""
        if self._exit_code is not None:
            return self._exit_code
        if self._pid_stat is not None:
            # Waits poll every slice and after each reply; a death is still seen within 20 ms.
            now = time.monotonic()
            if now - self._checked < 0.02:
                return None
            pid, start = self._pid_stat
            if start_time(pid) == start:
                self._checked = now
                return None
            self._pid_stat = None  # gone: ask the engine for the exit code
        try:
            state = self._api.inspect_container(self.id)["State"]
        except NotFound:
            self._exit_code = -1  # removed behind our back
            return self._exit_code
        if state["Status"] in ("exited", "dead"):
            self._exit_code = int(state["ExitCode"])
        return self._exit_code

    def logs(self, tail: int | None = None) -> str:
        """The container's output (stdout and stderr), or its last ``tail`` lines."""
        try:
            raw: bytes = self._api.logs(self.id, tail="all" if tail is None else tail)
        except NotFound:
            text = self._last_logs
            return text if tail is None else "\n".join(text.splitlines()[-tail:])
        return raw.decode(errors="replace")

    def log_tail(self, lines: int = 40) -> str:
        """The last ``lines`` lines of its output."""
        return self.logs(tail=lines)

    def host_port(self, container_port: int | str) -> int:
        """The loopback host port that ``container_port`` (e.g. 5556 or "14540/udp") is on."""
        key = _port_key(container_port)
        if key not in self.ports:
            raise ConfigurationError("container_port", container_port, f"one of {list(self.ports)}")
        return self.ports[key]

    def stop(self) -> None:
        """Stop and remove the container; raise NodeCrashedError if it had failed before."""
        if self._stopped:
            return
        self._stopped = True
        if not self._signalled:
            self._signal_stop()
        early = self._early
        try:
            if early is None:
                # docker counts whole seconds; with an init process it exits within ~0.2 s.
                with contextlib.suppress(NotFound):
                    self._api.stop(self.id, timeout=max(1, math.ceil(self.stop_timeout)))
            if (early not in (None, 0)) or self._log_dir is not None:
                self._last_logs = self.logs()
            if self._log_dir is not None:
                (self._log_dir / f"{self.name}.log").write_text(self._last_logs)
        finally:
            _remove_container(self._api, self.id)
        if early is not None and early != 0:
            raise NodeCrashedError(
                self.name,
                "had exited before it was stopped",
                exit_code=early,
                log_tail=self.log_tail(),
            )

    def _signal_stop(self) -> None:
        # First half of stop: note whether it had already failed, then ask it to exit.
        # Signalling every container of a simulation before waiting for any makes a
        # simulation stop in the time of one container, not of all of them in turn.
        if self._signalled:
            return
        self._signalled = True
        env = self._environment
        if env is not None and env.has_coordinator:
            env.coordinator.forget(self.name)
        self._early = self.poll()
        if self._early is None:
            with contextlib.suppress(APIError):
                self._api.kill(self.id, signal="SIGTERM")

    def __repr__(self) -> str:
        return f"ContainerNode({self.name!r}, id={self.id[:12]})"


def _engine_is_local() -> bool:
    host = os.environ.get("DOCKER_HOST", "")
    return not host or host.startswith("unix://")


def _remove_container(api: Any, container_id: str) -> None:
    try:
        api.remove_container(container_id, force=True, v=True)
    except NotFound:
        pass
    except APIError as exc:
        # Removal already in progress (the engine is stopping it): that is what we want.
        if exc.status_code != 409:
            raise


def _port_key(port: int | str) -> str:
    text = str(port)
    number, _, proto = text.partition("/")
    proto = proto or "tcp"
    if not number.isdigit() or not 1 <= int(number) <= 65535 or proto not in ("tcp", "udp"):
        raise ConfigurationError(
            "port", port, "a port number 1..65535, optionally '/tcp' or '/udp'"
        )
    return f"{int(number)}/{proto}"


def _default_name(args: list[str], image: str) -> str:
    # `multicosim serve pkg.mod:controller` -> "controller": the program names the component
    # better than the interpreter that runs it.
    for arg in args[1:]:
        if re.fullmatch(r"[\w.]+:[\w.]+", arg):
            return arg.rpartition(":")[2].rpartition(".")[2]
    first = Path(args[0]).name
    if first in ("python", "python3", "multicosim", "sh", "bash"):
        return image.rpartition("/")[2].partition(":")[0] or first
    return first


def _check_image(image: object) -> None:
    if not isinstance(image, str) or not image.strip() or any(c.isspace() for c in image):
        raise ConfigurationError("image", image, "a local image name such as 'name:tag'")


def _check_limits(limits: object) -> None:
    if not isinstance(limits, ContainerLimits):
        raise ConfigurationError("limits", limits, "a ContainerLimits")


def _check_env(env: object) -> None:
    if not isinstance(env, Mapping) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in env.items()
    ):
        raise ConfigurationError("env", env, "a mapping of str to str")


NONROOT_USER = "10001:10001"
"""The user (uid:gid) component containers run as unless told otherwise: not root, and not
a user of the host (the runtime image names it ``multicosim``)."""

_MEMORY = re.compile(r"(\d+)([bkmg]?)", re.IGNORECASE)
_UNITS = {"": 1, "b": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30}
_MIN_MEMORY = 6 << 20  # the engine refuses less


@dataclasses.dataclass(frozen=True)
class ContainerLimits:
    """What a component's container may use, and as whom it runs.

    ``user`` runs its program (``"uid:gid"`` or a name; None: the image's own user, which is
    often root); ``memory`` caps its memory, swap included (bytes, or ``"512m"``, ``"2g"``);
    ``pids`` caps its processes and threads (a fork bomb stops there). Whatever the limits,
    every container drops all Linux capabilities, cannot gain privileges
    (``no-new-privileges``), runs an init process, carries the run's labels, and joins only
    its simulation's network (never the host's).
    """

    user: str | None = NONROOT_USER
    memory: int | str = "2g"
    pids: int = 512

    def __post_init__(self) -> None:
        if self.user is not None and (
            not isinstance(self.user, str) or not self.user or any(c.isspace() for c in self.user)
        ):
            raise ConfigurationError("user", self.user, "None, 'uid:gid' or a user name")
        if _memory_bytes(self.memory) is None:
            raise ConfigurationError(
                "memory", self.memory, "bytes (an integer >= 6 MiB) or a size like '512m', '2g'"
            )
        if isinstance(self.pids, bool) or not isinstance(self.pids, int) or self.pids < 16:
            raise ConfigurationError("pids", self.pids, "an integer >= 16")

    def host_config(self) -> dict[str, Any]:
        """The engine's HostConfig settings these limits (and the fixed hardening) make."""
        memory = _memory_bytes(self.memory)
        return {
            "init": True,
            "cap_drop": ["ALL"],
            "security_opt": ["no-new-privileges:true"],
            "pids_limit": self.pids,
            "mem_limit": memory,
            "memswap_limit": memory,  # no swap beyond the memory limit
        }


def _memory_bytes(value: object) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        size = value
    elif isinstance(value, str) and (found := _MEMORY.fullmatch(value.strip())):
        size = int(found.group(1)) * _UNITS[found.group(2).lower()]
    else:
        return None
    return size if size >= _MIN_MEMORY else None


def _launch(
    environment: ContainerEnvironment,
    *,
    name: str,
    image: str,
    args: list[str],
    env: Mapping[str, str],
    publish: Mapping[str, int | None],
    share_with: ContainerNode | None,
    handshake: bool,
    start_timeout: float,
    stop_timeout: float,
    limits: ContainerLimits,
) -> tuple[ContainerNode, wire.Hello | None]:
    """Create and start one container; wait for its hello; clean it up if anything fails."""
    api = environment.client.api
    require_image(api, image, name)
    cname = environment.container_name(name)
    if share_with is None:
        network_mode = environment.network
        networking = api.create_networking_config(
            {environment.network: api.create_endpoint_config(aliases=[name])}
        )
    else:
        network_mode = f"container:{share_with.id}"
        networking = None
    host_config = api.create_host_config(
        network_mode=network_mode,
        port_bindings={key: ("127.0.0.1", hp) for key, hp in publish.items()} or None,
        **limits.host_config(),
    )
    order = environment.next_order()
    try:
        created = api.create_container(
            image,
            command=args,
            name=cname,
            environment={**environment.component_env(name), **env},
            labels={**environment.labels, LABEL_COMPONENT: name},
            user=limits.user,
            ports=[(int(k.split("/")[0]), k.split("/")[1]) for k in publish] or None,
            host_config=host_config,
            networking_config=networking,
            detach=True,
        )
    except APIError as exc:
        raise translate(exc, name=name) or exc from exc
    container = environment.client.containers.prepare_model({"Id": created["Id"], "Name": cname})
    node = ContainerNode(
        container,
        name=name,
        stop_timeout=stop_timeout,
        environment=environment,
        log_dir=environment.run_dir if environment.keep_logs else None,
    )
    environment.coordinator.expect(name, order, node)
    try:
        try:
            api.start(node.id)
        except APIError as exc:
            raise _start_error(name, publish, exc) from exc
        info = api.inspect_container(node.id)
        node._watch_pid(int(info["State"].get("Pid") or 0))
        bound = info["NetworkSettings"]["Ports"] or {}
        for key in publish:
            if not bound.get(key):
                # An exited container has no port bindings left to read.
                code = node.poll()
                if code is not None:
                    raise NodeStartError(
                        name, "exited before it was ready", exit_code=code, log_tail=node.log_tail()
                    )
                raise NodeStartError(name, f"port {key} was not published")
            node.ports[key] = int(bound[key][0]["HostPort"])
        hello = environment.coordinator.wait_ready(name, start_timeout) if handshake else None
    except BaseException:
        environment.coordinator.forget(name)
        _remove_container(api, node.id)
        raise
    return node, hello


def _start_error(name: str, publish: Mapping[str, int | None], exc: APIError) -> NodeStartError:
    text = str(exc.explanation or exc)
    if "already allocated" in text or "address already in use" in text:
        fixed = [f"127.0.0.1:{hp}" for hp in publish.values() if hp is not None]
        where = ", ".join(fixed) or "the requested host port"
        return NodeStartError(
            name, f"could not start: port {where} is already in use (use host_port=None)"
        )
    return NodeStartError(name, f"could not start: {text}")


@dataclasses.dataclass(frozen=True)
class ContainerComponent:
    """A component run as a container on the simulation's network (the paper's class).

    ``command`` runs in ``image`` (which must exist locally: images are never pulled).
    ``ready="handshake"`` (default) waits until the program joins the simulation (programs
    built with multicosim do); ``ready="started"`` is for arbitrary commands. ``ports`` are
    published on random loopback host ports (see ``ContainerNode.host_port``). On the network
    the container is reachable by the component's name.
    """

    image: str
    command: str | Sequence[str]
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    ports: Sequence[int | str] = ()
    ready: Literal["handshake", "started"] = "handshake"
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = DEFAULT_STOP_TIMEOUT
    limits: ContainerLimits = ContainerLimits()

    def __post_init__(self) -> None:
        _check_image(self.image)
        args = split_command(self.command)
        _check_env(self.env)
        _check_limits(self.limits)
        if isinstance(self.ports, str | int):
            raise ConfigurationError("ports", self.ports, "a sequence of ports, e.g. (14540,)")
        for port in self.ports:
            _port_key(port)
        if self.ready not in ("handshake", "started"):
            raise ConfigurationError("ready", self.ready, "'handshake' or 'started'")
        check_timeout("start_timeout", self.start_timeout)
        check_timeout("stop_timeout", self.stop_timeout)
        if self.name is None:
            object.__setattr__(self, "name", _default_name(args, self.image))

    def required_images(self) -> tuple[str, ...]:
        """The images this component needs locally."""
        return (self.image,)

    def start(self, environment: ContainerEnvironment) -> ContainerNode:
        """Start the container; with a handshake, return once it has joined the simulation."""
        return self._start(environment, None)

    def _start(
        self, environment: ContainerEnvironment, share: ContainerNode | None
    ) -> ContainerNode:
        assert self.name is not None
        node, _ = _launch(
            environment,
            name=self.name,
            image=self.image,
            args=split_command(self.command),
            env=self.env,
            publish={_port_key(p): None for p in self.ports},
            share_with=share,
            handshake=self.ready == "handshake",
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
            limits=self.limits,
        )
        return node


class ContainerFirmwareNode(ProcessFirmwareNode[MsgT, ReplyT]):
    """A firmware in a container: a CommunicationNode over ZeroMQ through a loopback port.

    ``container`` is its ContainerNode (logs, exit code); ``host_port`` the published port.
    """

    def __init__(
        self,
        container: ContainerNode,
        host_port: int,
        environment: ContainerEnvironment,
        *,
        msgtype: type[MsgT] | None,
        replytype: type[ReplyT] | None,
        timeout: float,
    ) -> None:
        super().__init__(
            container.name,
            f"tcp://127.0.0.1:{host_port}",
            msgtype=msgtype,
            replytype=replytype,
            timeout=timeout,
            watch=container,
            environment=environment,
            on_stop=container.stop,
            zctx=environment.zctx,
            token=environment.coordinator.token(container.name),
        )
        self.container = container
        self.host_port = host_port


@dataclasses.dataclass(frozen=True)
class ContainerFirmwareComponent(Generic[MsgT, ReplyT]):
    """A firmware in a container, reached as a CommunicationNode (the paper's class).

    ``{port}`` in ``command`` becomes ``port``, the container port the program serves on; it
    must bind all of the container's addresses, e.g.
    ``multicosim serve pkg.mod:controller --host 0.0.0.0 --port {port}``. The port is
    published on 127.0.0.1 only, on a random free host port unless ``host_port`` is given.
    """

    image: str
    command: str | Sequence[str]
    port: int = 5556
    msgtype: type[MsgT] | None = None
    replytype: type[ReplyT] | None = None
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    host_port: int | None = None
    timeout: float = DEFAULT_SEND_TIMEOUT
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = DEFAULT_STOP_TIMEOUT
    limits: ContainerLimits = ContainerLimits()

    def __post_init__(self) -> None:
        _check_image(self.image)
        args = split_command(self.command)
        _check_limits(self.limits)
        for field in ("port", "host_port"):
            value = getattr(self, field)
            if (value is not None or field == "port") and (
                isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 65535
            ):
                allowed = "an integer port in 1..65535" + (", or None" if field != "port" else "")
                raise ConfigurationError(field, value, allowed)
        check_types(self.msgtype, self.replytype)
        _check_env(self.env)
        for field in ("timeout", "start_timeout", "stop_timeout"):
            check_timeout(field, getattr(self, field))
        if self.name is None:
            object.__setattr__(self, "name", _default_name(args, self.image))

    def required_images(self) -> tuple[str, ...]:
        """The images this component needs locally."""
        return (self.image,)

    def start(self, environment: ContainerEnvironment) -> ContainerFirmwareNode[MsgT, ReplyT]:
        """Start the container, wait for its handshake and its answer through the port."""
        assert self.name is not None
        args = [a.replace("{port}", str(self.port)) for a in split_command(self.command)]
        key = f"{self.port}/tcp"
        container, _ = _launch(
            environment,
            name=self.name,
            image=self.image,
            args=args,
            env=self.env,
            publish={key: self.host_port},
            share_with=None,
            handshake=True,
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
            limits=self.limits,
        )
        node: ContainerFirmwareNode[MsgT, ReplyT] = ContainerFirmwareNode(
            container,
            container.ports[key],
            environment,
            msgtype=self.msgtype,
            replytype=self.replytype,
            timeout=self.timeout,
        )
        try:
            node.ping(timeout=min(self.start_timeout, _PORT_CHECK_TIMEOUT))
        except BaseException as exc:
            tail = container.log_tail()
            with contextlib.suppress(Exception):
                node.stop()
            if isinstance(exc, NodeTimeoutError):
                raise NodeStartError(
                    self.name,
                    f"joined the simulation but does not answer on container port {self.port}: "
                    "its command must bind all addresses (--host 0.0.0.0) on that port",
                    log_tail=tail,
                ) from exc
            raise
        return node


class _HostComponent(Protocol[HostT_co]):
    """What AttachedComponent needs of its host: a container component with a name."""

    @property
    def name(self) -> str | None: ...
    @property
    def image(self) -> str: ...
    def start(self, environment: ContainerEnvironment) -> HostT_co: ...


class AttachedNode(Generic[HostT]):
    """A running AttachedComponent: the host's node and the attached containers' nodes."""

    def __init__(self, host: HostT, attached: Sequence[ContainerNode], name: str) -> None:
        self.host = host
        self.attached = tuple(attached)
        self.name = name
        self._stopped = False

    def stop(self) -> None:
        """Stop the attached containers (newest first), then the host."""
        if self._stopped:
            return
        self._stopped = True
        from ..local.simulation import stop_all

        steps = [(f"container {n.name!r}", n.stop) for n in reversed(self.attached)]
        stop_all([*steps, (f"host {self.name!r}", self.host.stop)], f"attached {self.name!r}")


def _container_of(node: Node) -> ContainerNode:
    container = node if isinstance(node, ContainerNode) else getattr(node, "container", None)
    assert isinstance(container, ContainerNode)
    return container


@dataclasses.dataclass(frozen=True)
class AttachedComponent(Generic[HostT]):
    """Containers sharing one network stack (the paper's AttachedComponent).

    Only ``host`` (a ContainerComponent or ContainerFirmwareComponent) joins the simulation's
    network and publishes ports; every ``attached`` container reuses its network stack, so
    they all talk to each other over localhost.
    """

    host: _HostComponent[HostT]
    attached: Sequence[ContainerComponent]
    name: str | None = None

    def __post_init__(self) -> None:
        host: object = self.host  # checked at run time: the annotation is not enforced
        if not isinstance(host, ContainerComponent | ContainerFirmwareComponent):
            raise ConfigurationError(
                "host", self.host, "a ContainerComponent or ContainerFirmwareComponent"
            )
        if isinstance(self.attached, ContainerComponent) or not all(
            isinstance(c, ContainerComponent) for c in self.attached
        ):
            raise ConfigurationError("attached", self.attached, "a sequence of ContainerComponent")
        for comp in self.attached:
            if comp.ports:
                raise ConfigurationError(
                    "ports", comp.ports, "no ports on attached containers (publish on the host)"
                )
        names = self.node_names()
        if len(set(names)) != len(names):
            raise ConfigurationError("name", names, "distinct names for host and attached")
        if self.name is None:
            object.__setattr__(self, "name", self.host.name)

    def node_names(self) -> list[str]:
        """The names under which the host and the attached containers join the simulation."""
        host_name = self.host.name
        assert host_name is not None
        return [host_name, *(str(c.name) for c in self.attached)]

    def required_images(self) -> tuple[str, ...]:
        """The images this component needs locally."""
        return tuple(dict.fromkeys([self.host.image, *(c.image for c in self.attached)]))

    def start(self, environment: ContainerEnvironment) -> AttachedNode[HostT]:
        """Start the host, then each attached container in its network stack."""
        assert self.name is not None
        host = self.host.start(environment)
        started: list[ContainerNode] = []
        try:
            for comp in self.attached:
                started.append(comp._start(environment, _container_of(host)))
        except BaseException as exc:
            node = AttachedNode(host, started, self.name)
            try:
                node.stop()
            except BaseExceptionGroup as group:
                exc.add_note(f"stopping the partial group also failed: {group!r}")
            raise
        return AttachedNode(host, started, self.name)
