"""ContainerFirmwareComponent: a firmware in a container, reached as a CommunicationNode.

The host reaches it through its port, published on a random loopback port; once the
firmware has joined the simulation, it must also answer there.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Mapping, Sequence
from typing import Generic

from ..core.errors import ConfigurationError, NodeStartError, NodeTimeoutError
from ..core.interfaces import Node
from ..core.messages import MsgT, ReplyT
from ..local.firmware import ProcessFirmwareNode, check_types
from ..local.processes import split_command
from ..local.waits import DEFAULT_SEND_TIMEOUT, DEFAULT_START_TIMEOUT, check_timeout
from ._component import _check_env, _check_image, _default_name, _launch
from ._limits import ContainerLimits, _check_limits
from .environment import ContainerEnvironment
from .node import DEFAULT_STOP_TIMEOUT, ContainerNode

__all__ = ["ContainerFirmwareComponent", "ContainerFirmwareNode"]

# How long a started firmware may take to answer through its published port once it has
# said hello (the port proxy is already up by then; this only catches a wrong bind address).
_PORT_CHECK_TIMEOUT = 5.0


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

    def parts(self) -> list[Node]:
        """Its container."""
        return [self.container]


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
            mounts={},
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
