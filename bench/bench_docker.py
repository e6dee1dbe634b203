"""Docker backend overhead against raw Docker + raw ZeroMQ, side by side in one run.

1. start-to-ready: ``ContainerFirmwareComponent.start`` (create, start, handshake through
   the lockstep coordinator, answer through the published port) against ``containers.run``
   of the same image and command + polling the published port with raw pyzmq until the
   first reply.
   Measured for a component joining a running simulation and for a whole
   ``ContainerSimulator.start`` (which also creates the network).
2. stop: ``node.stop()`` (stop and remove the container) against ``container.stop()`` +
   ``remove()`` of the raw container.
3. round trip: ``node.send(Echo(...))`` through the published port against a raw pyzmq
   DEALER sending the same frame to the same container.

Usage: ``python bench/bench_docker.py [--starts N] [--calls N] [--quick]``; needs a running
engine and the runtime image (``multicosim images build``); without them it
writes the reason and exits. Prints a table and writes ``bench/results/docker.json``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import msgspec
import zmq
from _common import docker_reason, write_result

from multicosim.core import wire
from multicosim.core.messages import encode, type_name
from multicosim.docker import (
    RUNTIME_IMAGE,
    ContainerFirmwareComponent,
    ContainerSimulator,
)
from multicosim.docker import _selftest as st
from multicosim.docker.engine import client, labels

COMMAND = "multicosim serve multicosim.docker._selftest:echo --host 0.0.0.0 --port {port}"
PORT = 5556


def _firmware(name: str = "echo") -> ContainerFirmwareComponent[st.Echo, st.EchoReply]:
    return ContainerFirmwareComponent(
        image=RUNTIME_IMAGE,
        command=COMMAND,
        port=PORT,
        name=name,
        msgtype=st.Echo,
        replytype=st.EchoReply,
    )


def raw_start(docker: Any, zctx: zmq.Context[Any]) -> tuple[float, Any, int]:
    """``docker run`` + poll the published port with pings until one answers."""
    t0 = time.perf_counter()
    container = docker.containers.run(
        RUNTIME_IMAGE,
        COMMAND.replace("{port}", str(PORT)).split(),
        detach=True,
        init=True,
        ports={f"{PORT}/tcp": ("127.0.0.1", None)},
        labels=labels("bench-raw"),
    )
    container.reload()
    host_port = int(container.ports[f"{PORT}/tcp"][0]["HostPort"])
    sock = zctx.socket(zmq.DEALER)
    sock.setsockopt(zmq.LINGER, 0)
    # The port proxy accepts before the program listens and then drops the connection: retry
    # fast (ZeroMQ waits 100 ms by default) so the baseline is the best raw case.
    sock.setsockopt(zmq.RECONNECT_IVL, 5)
    sock.connect(f"tcp://127.0.0.1:{host_port}")
    ping = 0
    while True:
        ping += 1
        sock.send(wire.encoder.encode(wire.Ping(ping)))
        if sock.poll(5):
            sock.recv()
            break
    elapsed = time.perf_counter() - t0
    sock.close(0)
    return elapsed, container, host_port


def bench_start(n: int) -> dict[str, list[float]]:
    """Interleaved start-to-ready samples of the raw path and ours."""
    docker = client()
    zctx: zmq.Context[Any] = zmq.Context()
    samples: dict[str, list[float]] = {
        "raw": [],
        "component": [],
        "simulation": [],
        "raw_stop": [],
        "component_stop": [],
    }
    holder = ContainerSimulator()
    holder_sim = holder.start()  # a running simulation that components join
    try:
        for i in range(n):
            elapsed, container, _ = raw_start(docker, zctx)
            samples["raw"].append(elapsed)
            t0 = time.perf_counter()
            container.stop(timeout=5)
            container.remove(force=True)
            samples["raw_stop"].append(time.perf_counter() - t0)

            t0 = time.perf_counter()
            node = _firmware(f"echo{i}").start(holder_sim.environment)
            samples["component"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            node.stop()
            samples["component_stop"].append(time.perf_counter() - t0)

            sim = ContainerSimulator()
            sim.add(_firmware())
            t0 = time.perf_counter()
            running = sim.start()
            samples["simulation"].append(time.perf_counter() - t0)
            running.stop()
    finally:
        holder_sim.stop()
        zctx.destroy(linger=0)
    return samples


def bench_rtt(calls: int, blocks: int = 5) -> dict[str, list[float]]:
    """Interleaved blocks of round trips: node.send against a raw DEALER.

    A component answers its simulation host only, so the raw DEALER talks to the same
    program in a raw container of its own (``docker run``, published on loopback as ours).
    """
    sim = ContainerSimulator()
    fw = sim.add(_firmware())
    samples: dict[str, list[float]] = {"raw": [], "send": []}
    zctx: zmq.Context[Any] = zmq.Context()
    _, raw, raw_port = raw_start(client(), zctx)
    with sim.start() as running:
        node = running.get(fw)
        sock = zctx.socket(zmq.DEALER)
        sock.setsockopt(zmq.LINGER, 0)
        sock.connect(f"tcp://127.0.0.1:{raw_port}")
        msg = st.Echo("x")
        decoder = wire.from_firmware
        reply_decoder = msgspec.msgpack.Decoder(st.EchoReply)
        for _ in range(200):  # warm both paths up
            node.send(msg)
        call_id = 0
        for _ in range(blocks):
            t0 = time.perf_counter()
            for _ in range(calls):
                call_id += 1
                frame = wire.Call(call_id, type_name(st.Echo), encode(msg))
                sock.send(wire.encoder.encode(frame))
                answer = decoder.decode(sock.recv())
                assert isinstance(answer, wire.Reply)
                reply_decoder.decode(answer.payload)  # as send does: a typed reply
            samples["raw"].append((time.perf_counter() - t0) / calls)
            t0 = time.perf_counter()
            for _ in range(calls):
                node.send(msg)
            samples["send"].append((time.perf_counter() - t0) / calls)
        sock.close(0)
    raw.remove(force=True)
    zctx.destroy(linger=0)
    return samples


def main(argv: list[str] | None = None) -> int:
    """Run both benchmarks, print the table, write bench/results/docker.json."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=7, help="start samples per path")
    parser.add_argument("--calls", type=int, default=2000, help="round trips per block")
    parser.add_argument("--quick", action="store_true", help="3 starts, 500 calls per block")
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args(argv)
    if args.quick:
        args.starts, args.calls = 3, 500
    reason = docker_reason()
    if reason is not None:
        print(f"skipped: {reason}", file=sys.stderr)
        write_result("docker", {"skipped": reason}, args.output)
        return 0
    starts = bench_start(args.starts)
    rtts = bench_rtt(args.calls)
    med = {k: statistics.median(v) for k, v in starts.items()}
    rtt = {k: statistics.median(v) for k, v in rtts.items()}
    rows = [
        ("start-to-ready: raw docker run + first reply", med["raw"] * 1e3, "ms", None),
        (
            "start-to-ready: ContainerFirmwareComponent.start",
            med["component"] * 1e3,
            "ms",
            med["component"] / med["raw"],
        ),
        (
            "start-to-ready: ContainerSimulator.start (+ network)",
            med["simulation"] * 1e3,
            "ms",
            med["simulation"] / med["raw"],
        ),
        ("stop: raw docker stop + remove", med["raw_stop"] * 1e3, "ms", None),
        (
            "stop: node.stop()",
            med["component_stop"] * 1e3,
            "ms",
            med["component_stop"] / med["raw_stop"],
        ),
        ("round trip: raw pyzmq, published port", rtt["raw"] * 1e6, "us", None),
        ("round trip: ProcessFirmwareNode.send", rtt["send"] * 1e6, "us", rtt["send"] / rtt["raw"]),
    ]
    print(f"{'measure':<56} {'median':>10}  {'ratio':>6}")
    for label, value, unit, ratio in rows:
        r = f"{ratio:6.2f}" if ratio is not None else "     -"
        print(f"{label:<56} {value:>7.2f} {unit}  {r}")
    result = {
        "image": RUNTIME_IMAGE,
        "start_ready_s": starts,
        "round_trip_s": rtts,
        "median": {"start_ready_s": med, "round_trip_s": rtt},
        "ratios": {
            "component_start_vs_raw": med["component"] / med["raw"],
            "simulation_start_vs_raw": med["simulation"] / med["raw"],
            "component_stop_vs_raw": med["component_stop"] / med["raw_stop"],
            "send_vs_raw_zmq": rtt["send"] / rtt["raw"],
        },
        "targets": {"component_start_vs_raw": 1.2, "send_vs_raw_zmq": 1.5},
    }
    out = write_result("docker", result, args.output)
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
