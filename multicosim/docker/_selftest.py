"""Small component programs shipped in the runtime image for the Docker backend's own tests
and benchmarks. They import only the core (no Docker SDK), so they run in any container.

* ``echo``: a firmware that answers at once (no simulated time), or exits on request;
* ``World`` + ``controller``: a participant and a firmware in lockstep (a 1-D cart);
* ``relay`` + ``python -m multicosim.docker._selftest localhost-server``: two programs that
  talk over the localhost of a shared network stack (an AttachedComponent).
"""

from __future__ import annotations

import argparse
import os
import socket
import sys

from ..core.messages import Message
from ..runtime import FirmwareContext, StepContext, firmware

__all__ = [
    "Cmd",
    "Echo",
    "EchoReply",
    "Mission",
    "State",
    "Trajectory",
    "World",
    "controller",
    "echo",
    "main",
    "relay",
]

RELAY_PORT = 7001


class Echo(Message):
    """A message to echo; ``exit_code`` >= 0 makes the echo firmware exit with it instead."""

    text: str
    exit_code: int = -1


class EchoReply(Message):
    """The echo: the text, who answered and the seed it was given."""

    text: str
    host: str
    node: str
    seed: int


@firmware(msgtype=Echo, period=0.01)
def echo(msg: Echo, ctx: FirmwareContext) -> EchoReply:
    """Answer at once; exit the process if asked to (to test crash reporting)."""
    if msg.exit_code >= 0:
        print(f"echo: exiting with {msg.exit_code} as asked", flush=True)
        os._exit(msg.exit_code)
    return EchoReply(msg.text, socket.gethostname(), ctx.name, ctx.seed)


class Mission(Message):
    """Drive at ``speed`` for ``steps`` controller periods."""

    speed: float
    steps: int = 10


class Trajectory(Message):
    """Controller step times and the cart position seen at each."""

    times: list[float]
    xs: list[float]


class Cmd(Message):
    """Velocity command."""

    speed: float


class State(Message):
    """Cart position."""

    x: float


class World:
    """A 1-D cart integrated every 10 ms of simulated time."""

    period = 0.01

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to commands."""
        self.x = 0.0
        self.v = 0.0
        self.cmd = ctx.subscribe("cmd", Cmd)

    def step(self, ctx: StepContext) -> None:
        """Integrate and publish the position."""
        if self.cmd.latest is not None:
            self.v = self.cmd.latest.speed
        self.x += self.v * self.period
        ctx.publish("state", State(x=self.x))


@firmware(msgtype=Mission, period=0.05)
def controller(mission: Mission, ctx: FirmwareContext) -> Trajectory:
    """Command ``mission.speed`` every period and record what the world reports."""
    state = ctx.subscribe("state", State)
    times: list[float] = []
    xs: list[float] = []
    for _ in range(mission.steps):
        ctx.step()
        times.append(ctx.time)
        xs.append(state.latest.x if state.latest is not None else -1.0)
        ctx.publish("cmd", Cmd(speed=mission.speed))
    return Trajectory(times, xs)


@firmware(msgtype=Echo, period=0.01)
def relay(msg: Echo, ctx: FirmwareContext) -> EchoReply:
    """Forward the text to the localhost server and return its answer."""
    import zmq

    port = int(os.environ.get("MCS_SELFTEST_PORT", RELAY_PORT))
    timeout_ms = int(os.environ.get("MCS_SELFTEST_TIMEOUT_MS", 10_000))
    sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    try:
        sock.connect(f"tcp://127.0.0.1:{port}")
        sock.send_string(msg.text)
        if not sock.poll(timeout_ms):
            raise TimeoutError(f"nothing answers on localhost:{port}")
        return EchoReply(sock.recv_string(), socket.gethostname(), ctx.name, ctx.seed)
    finally:
        sock.close(0)


def _localhost_server(port: int) -> None:
    import signal

    import zmq

    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.REP)
    sock.setsockopt(zmq.LINGER, 0)
    # Loopback only: reachable solely from containers sharing this network stack.
    sock.bind(f"tcp://127.0.0.1:{port}")
    print(f"localhost-server on 127.0.0.1:{port}", flush=True)
    while True:
        text = sock.recv_string()
        sock.send_string(f"{socket.gethostname()} says {text}")


def main(argv: list[str] | None = None) -> int:
    """``python -m multicosim.docker._selftest localhost-server [--port N]``."""
    parser = argparse.ArgumentParser(prog="multicosim.docker._selftest")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("localhost-server", help="answer REQ on 127.0.0.1 only")
    p.add_argument("--port", type=int, default=RELAY_PORT)
    args = parser.parse_args(argv)
    if args.command == "localhost-server":
        _localhost_server(args.port)
    return 0


if __name__ == "__main__":
    sys.exit(main())
