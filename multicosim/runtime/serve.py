"""Firmware and component programs: the ``@firmware`` decorator and the programs that run
components outside the simulation's process.

* [`Firmware`][multicosim.runtime.serve.Firmware] / [`firmware`][multicosim.runtime.serve.firmware]:
  a handler called with each message sent to its node, advancing the simulated clock itself, whose
  return value is the reply;
* [`serve`][multicosim.runtime.serve.serve] (``multicosim serve MODULE:FIRMWARE --port N``) answers
  calls to a firmware; [`run_participant`][multicosim.runtime.serve.run_participant] (``multicosim
  participant MODULE:FACTORY``) steps a participant;
* [`load_target`][multicosim.runtime.serve.load_target] and ``build_from_config`` find a component
  by ``module:name`` and build it from its JSON configuration.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import logging
import os
import signal
import threading
import traceback
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Generic

import msgspec

from ..core import wire
from ..core.clock import to_ns
from ..core.errors import (
    ConfigurationError,
    MulticosimError,
    SimulationStopped,
    TransportError,
    translate,
)
from ..core.messages import MsgT, ReplyT, decode, encode, type_name
from .context import FirmwareContext, Participant, StepContext, derive_seed
from .transport import _PARENT_CHECK_MS, Connection, RemoteDriver, _inbox, _outbox

if TYPE_CHECKING:
    import zmq

__all__ = [
    "Firmware",
    "build_from_config",
    "check_port_number",
    "default_bind_host",
    "firmware",
    "handle_call",
    "load_target",
    "port_argument",
    "run_participant",
    "serve",
]

log = logging.getLogger(__name__)


class Firmware(Generic[MsgT, ReplyT]):
    """A firmware: the handler, the message type it accepts and its step period.

    It wears its handler's name, docstring, module and signature (``help()``,
    ``inspect.signature`` and documentation tools show the handler's), as
    ``functools.wraps`` makes a wrapper do.
    """

    # Set by functools.update_wrapper from the handler.
    __name__: str
    __qualname__: str
    __wrapped__: Callable[[MsgT, FirmwareContext], ReplyT]

    def __init__(
        self,
        handler: Callable[[MsgT, FirmwareContext], ReplyT],
        msgtype: type[MsgT],
        period: float,
        name: str,
    ) -> None:
        self.handler = handler
        self.msgtype = msgtype
        self.period = period
        self.period_ns = to_ns(period)
        self.name = name
        functools.update_wrapper(self, handler)

    def __call__(self, msg: MsgT, ctx: FirmwareContext) -> ReplyT:
        return self.handler(msg, ctx)

    def __repr__(self) -> str:
        return f"Firmware({self.name!r}, msgtype={type_name(self.msgtype)})"

    def main(self, argv: list[str] | None = None) -> None:
        """Command-line entry: ``PROGRAM --port PORT [--host HOST]``; serves until stopped."""
        import argparse

        parser = argparse.ArgumentParser(prog=self.name, description=f"serve {self!r}")
        parser.add_argument(
            "--port", type=port_argument, default=0, help="port to serve on (0: any)"
        )
        parser.add_argument(
            "--host", default=default_bind_host(), help="address to bind (env MCS_BIND_HOST)"
        )
        args = parser.parse_args(argv)
        serve(self, port=args.port, host=args.host)


def firmware(
    *, msgtype: type[MsgT], period: float = 0.01, name: str | None = None
) -> Callable[[Callable[[MsgT, FirmwareContext], ReplyT]], Firmware[MsgT, ReplyT]]:
    """Declare a firmware handler, the paper's component-side program:

    ```python
    @mcs.firmware(msgtype=Mission, period=0.02)
    def controller(mission: Mission, ctx: mcs.FirmwareContext) -> Trajectory:
        ...
    ```
    """
    if not isinstance(msgtype, type):
        raise ConfigurationError("msgtype", msgtype, "a message type (a class)")

    def wrap(handler: Callable[[MsgT, FirmwareContext], ReplyT]) -> Firmware[MsgT, ReplyT]:
        return Firmware(handler, msgtype, period, name or handler.__name__)

    return wrap


def handle_call(
    fw: Firmware[Any, Any], call: wire.Call, ctx: FirmwareContext
) -> wire.Reply | wire.Failure:
    """Decode, validate and handle one call; failures become Failure frames."""
    expected = type_name(fw.msgtype)
    if call.msgtype != expected:
        return wire.Failure(
            call.id, "type", "MessageTypeError", f"{fw.name} expects {expected}, got {call.msgtype}"
        )
    try:
        msg = decode(call.payload, fw.msgtype, what=f"message to {fw.name!r}")
    except TransportError as exc:
        return wire.Failure(call.id, "validation", "TransportError", str(exc))
    try:
        try:
            result = fw.handler(msg, ctx)
        finally:
            ctx.end_call()
        return wire.Reply(call.id, encode(result))
    except SimulationStopped:
        raise
    except Exception as exc:
        return wire.Failure(
            call.id, "exception", type(exc).__name__, str(exc), traceback.format_exc()
        )


# -- component programs ---------------------------------------------------------------------


def default_bind_host() -> str:
    """Where a firmware binds unless told: MCS_BIND_HOST (0.0.0.0 in images), else loopback."""
    return os.environ.get(wire.ENV_BIND_HOST, "127.0.0.1")


def _environment() -> tuple[str | None, str, int]:
    address = os.environ.get(wire.ENV_COORDINATOR)
    name = os.environ.get(wire.ENV_NODE_NAME, "component")
    seed = int(os.environ.get(wire.ENV_SEED, "0"))
    return address, name, seed


def _token(address: str | None) -> str | None:
    token = os.environ.get(wire.ENV_TOKEN) or None
    if address is not None and token is None:
        raise MulticosimError(
            f"{wire.ENV_TOKEN} is not set: components join a simulation only when its "
            "simulator starts them"
        )
    return token


def port_argument(text: str) -> int:
    """The type of a ``--port`` option: 0 (any free port) or 1..65535; nothing wraps around."""
    import argparse

    try:
        return check_port_number(int(text))
    except (ValueError, ConfigurationError):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a port: expected 1..65535, or 0 for any free port"
        ) from None


def check_port_number(port: object) -> int:
    """Return ``port`` if it is a TCP port a firmware can bind: 1..65535, or 0 for any."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ConfigurationError("port", port, "an integer in 1..65535, or 0 for any free port")
    return port


def _install_sigterm() -> None:
    # Python ignores SIGTERM as PID 1 in a container; turn it into a clean exit everywhere.
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(SystemExit(0)))


def run_participant(participant: Participant) -> None:
    """Run ``participant`` as a process, stepped by the coordinator named in the environment."""
    address, name, seed = _environment()
    if address is None:
        raise MulticosimError(
            f"{wire.ENV_COORDINATOR} is not set: participants are started by a simulator"
        )
    token = _token(address)
    _install_sigterm()
    ctx = StepContext(name, derive_seed(seed, name))
    participant.setup(ctx)
    period_ns = to_ns(participant.period)
    conn = Connection(address, name, token=token, own_process=True)
    try:
        outbox, topics = ctx._take()
        conn.send(wire.Hello(name, period_ns, False, topics, os.getpid()))
        pending = _outbox(outbox)
        while True:
            step = conn.recv()
            assert isinstance(step, wire.Step)
            ctx._begin(step.time_ns, _inbox(step))
            participant.step(ctx)
            outbox, topics = ctx._take()
            conn.send(wire.Yield(step.time_ns + period_ns, pending + _outbox(outbox), topics))
            pending = []
    except SimulationStopped as exc:
        log.info("%s", exc)
    finally:
        conn.close()


def serve(
    fw: Firmware[Any, Any],
    *,
    port: int = 0,
    host: str | None = None,
    stop: threading.Event | None = None,
    zctx: zmq.Context[Any] | None = None,
    environment: tuple[str | None, str, int] | None = None,
    token: str | None = None,
) -> None:
    """Serve ``fw`` on ``host:port`` until the simulation stops it (or ``stop`` is set).

    Each call is decoded and validated against ``fw.msgtype``; the handler's return value is
    the reply, an exception becomes a RemoteError on the caller's side. Within a simulation
    the firmware says hello to the coordinator, which is how the host knows it is ready, and
    answers only its host (calls must come from the identity ``token``, ``MCS_TOKEN`` by
    default); other frames are dropped with a warning. ``port`` 0 binds any free port.
    """
    import zmq

    check_port_number(port)
    if environment is None:
        environment = _environment()
        token = token or _token(environment[0])
    address, name, seed = environment
    host = host or default_bind_host()
    if stop is None:
        _install_sigterm()
    zctx = zctx or zmq.Context.instance()
    rpc = zctx.socket(zmq.ROUTER)
    wire.listen_options(rpc)
    try:
        if port == 0:
            rpc.bind_to_random_port(f"tcp://{host}")
        else:
            rpc.bind(f"tcp://{host}:{port}")
    except zmq.ZMQError as exc:  # the port is taken, or the host is not an address of ours
        rpc.close(0)
        raise translate(exc, name=f"firmware {name!r} on tcp://{host}:{port}") or exc from exc
    endpoint = rpc.getsockopt_string(zmq.LAST_ENDPOINT)
    bound = int(endpoint.rsplit(":", 1)[1])
    where = f"firmware {name!r} at {endpoint}"
    drops = wire.Drops(where, log)
    refused = wire.HandshakeFailures(rpc, where, log)
    caller = token.encode() if token else None
    conn = (
        Connection(address, name, zctx, token=token, own_process=stop is None) if address else None
    )
    poller = zmq.Poller()
    poller.register(rpc, zmq.POLLIN)
    # Logged before the handshake, so that the line is in the log of every ready firmware.
    log.info("%s serving %r on %s", name, fw, endpoint)
    if conn is not None:
        poller.register(conn.socket, zmq.POLLIN)
        conn.send(wire.Hello(name, fw.period_ns, True, [], os.getpid(), bound))
    ppid = os.getppid()
    fw_seed = derive_seed(seed, name)
    try:
        while stop is None or not stop.is_set():
            events = dict(poller.poll(200 if stop is not None else _PARENT_CHECK_MS))
            if conn is not None and conn.socket in events:
                frame = wire.to_participant.decode(conn.socket.recv())
                if isinstance(frame, wire.Stop):
                    break
            if rpc in events:
                received = _receive_call(rpc, caller, drops)
                if received is None:
                    continue
                ident, request = received
                if isinstance(request, wire.Ping):
                    answer: Any = wire.Pong(request.id, name, type_name(fw.msgtype))
                else:
                    driver = RemoteDriver(conn) if conn is not None else None
                    ctx = FirmwareContext(name, fw_seed, fw.period_ns, driver)
                    ctx.time_ns = request.time_ns
                    answer = handle_call(fw, request, ctx)
                rpc.send_multipart([ident, wire.encoder.encode(answer)])
            if (
                stop is None
                and not events
                and (conn.orphaned() if conn is not None else os.getppid() != ppid)
            ):
                log.info("%s: the simulation host has gone", name)
                break
    except SimulationStopped as exc:
        log.info("%s", exc)
    finally:
        refused.close()
        rpc.close(0)
        if conn is not None:
            conn.close()


def _receive_call(
    rpc: zmq.Socket[Any], caller: bytes | None, drops: wire.Drops
) -> tuple[bytes, wire.Call | wire.Ping] | None:
    """The next call on a firmware's socket, or None if it was dropped (and why is logged)."""
    head, parts = wire.receive(rpc)
    ident = head.bytes
    if caller is not None and ident != caller:
        drops.drop(wire.describe_peer(head), "not the simulation host")
        return None
    if len(parts) != 1:
        drops.drop(wire.describe_peer(head), f"a message of {len(parts)} frames, not 1")
        return None
    try:
        request: wire.Call | wire.Ping = wire.to_firmware.decode(parts[0])
    except msgspec.DecodeError as exc:
        drops.drop(wire.describe_peer(head), f"not a call ({exc})")
        return None
    return ident, request


def load_target(target: str) -> Any:
    """The object ``MODULE:ATTRIBUTE`` names (ValueError if ``target`` is not of that form)."""
    module_name, sep, attr = target.partition(":")
    if not sep or not module_name or not attr:
        raise ValueError(f"expected MODULE:ATTRIBUTE, got {target!r}")
    module = importlib.import_module(module_name)
    obj: Any = module
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def build_from_config(factory: Callable[..., Any], config: str | None) -> Any:
    """Call ``factory``, decoding ``config`` (JSON) as its first parameter's type."""
    if config is None:
        return factory()
    import msgspec

    params = list(inspect.signature(factory).parameters.values())
    if not params:
        raise SystemExit(f"error: {factory!r} takes no configuration")
    hints = inspect.get_annotations(factory, eval_str=True) if inspect.isfunction(factory) else {}
    if inspect.isclass(factory):
        hints = inspect.get_annotations(factory.__init__, eval_str=True)
    tp = hints.get(params[0].name, Any)
    return factory(msgspec.json.decode(config.encode(), type=tp))
