"""ContainerComponent, and how any component's container is created, started and cleaned up.

A container runs as a non-root user, without capabilities, within memory and process limits
([`ContainerLimits`][multicosim.docker._component.ContainerLimits]), on its simulation's network
only; a container that fails to start is removed before the error propagates.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Literal

from ..core import wire
from ..core.errors import ConfigurationError, NodeStartError, translate
from ..local.processes import split_command
from ..local.waits import DEFAULT_START_TIMEOUT, check_timeout, ending
from ._limits import ContainerLimits, _check_limits
from .engine import LABEL_COMPONENT, APIError, require_image
from .environment import ContainerEnvironment
from .node import DEFAULT_STOP_TIMEOUT, ContainerNode, _port_key, _remove_container

__all__ = ["ContainerComponent"]


def _image_name(image: str) -> str:
    # "ghcr.io/lab/examples/rover/gazebo:1.0" -> "gazebo"
    return image.rpartition("/")[2].partition(":")[0]


def _default_name(args: list[str] | None, image: str) -> str:
    if args is None:
        return _image_name(image) or "container"  # the image's own command: its name
    # `multicosim serve pkg.mod:controller` -> "controller": the program names the component
    # better than the interpreter that runs it.
    for arg in args[1:]:
        if re.fullmatch(r"[\w.]+:[\w.]+", arg):
            return arg.rpartition(":")[2].rpartition(".")[2]
    first = Path(args[0]).name
    if first in ("python", "python3", "multicosim", "sh", "bash"):
        return _image_name(image) or first
    return first


def _check_image(image: object) -> None:
    if not isinstance(image, str) or not image.strip() or any(c.isspace() for c in image):
        raise ConfigurationError("image", image, "a local image name such as 'name:tag'")


def _check_env(env: object) -> None:
    if not isinstance(env, Mapping) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in env.items()
    ):
        raise ConfigurationError("env", env, "a mapping of str to str")


def _check_mounts(mounts: object) -> None:
    allowed = (
        "a mapping of an existing absolute path on this machine to an absolute path in the "
        "container, neither with ':' (mounted read-only)"
    )
    if not isinstance(mounts, Mapping):
        raise ConfigurationError("mounts", mounts, allowed)
    for host, inside in mounts.items():
        # The engine takes a bind as "host:container:mode": a ':' in a path would split it.
        ok = (
            isinstance(host, str)
            and isinstance(inside, str)
            and Path(host).is_absolute()
            and inside.startswith("/")
            and ":" not in host + inside
        )
        if not ok or not Path(host).exists():
            raise ConfigurationError("mounts", {host: inside}, allowed)


def _launch(
    environment: ContainerEnvironment,
    *,
    name: str,
    image: str,
    args: list[str] | None,
    env: Mapping[str, str],
    publish: Mapping[str, int | None],
    share_with: ContainerNode | None,
    mounts: Mapping[str, str],
    handshake: bool,
    start_timeout: float,
    stop_timeout: float,
    limits: ContainerLimits,
) -> tuple[ContainerNode, wire.Hello | None]:
    """Create and start one container; wait for its hello; clean it up if anything fails.

    ``args`` None runs the image's own command (its ``CMD``, after its ``ENTRYPOINT``).
    """
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
        binds={host: {"bind": inside, "mode": "ro"} for host, inside in mounts.items()} or None,
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
    node.memory = limits.memory_bytes
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
                        name,
                        f"{ending(node)} before it was ready",
                        exit_code=code,
                        log_tail=node.log_tail(),
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

    ``command`` runs in ``image`` (which must exist locally: images are never pulled); None
    (the default) runs the image's own command, as ``docker run IMAGE`` does, so that an
    image made for one component needs nothing but its name: ``ContainerComponent(image=...)``.
    ``ready="handshake"`` (default) waits until the program joins the simulation (programs
    built with multicosim do); ``ready="started"`` is for arbitrary commands. ``ports`` are
    published on random loopback host ports (see ``ContainerNode.host_port``). ``mounts``
    maps paths of this machine to paths in the container, mounted read-only. On the network
    the container is reachable by the component's name.
    """

    image: str
    command: str | Sequence[str] | None = None
    name: str | None = None
    env: Mapping[str, str] = dataclasses.field(default_factory=dict)
    ports: Sequence[int | str] = ()
    ready: Literal["handshake", "started"] = "handshake"
    start_timeout: float = DEFAULT_START_TIMEOUT
    stop_timeout: float = DEFAULT_STOP_TIMEOUT
    limits: ContainerLimits = ContainerLimits()
    mounts: Mapping[str, str] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_image(self.image)
        args = self._args()
        _check_env(self.env)
        _check_mounts(self.mounts)
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

    def _args(self) -> list[str] | None:
        return None if self.command is None else split_command(self.command)

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
            args=self._args(),
            env=self.env,
            publish={_port_key(p): None for p in self.ports},
            share_with=share,
            mounts=self.mounts,
            handshake=self.ready == "handshake",
            start_timeout=self.start_timeout,
            stop_timeout=self.stop_timeout,
            limits=self.limits,
        )
        return node
