"""``python -m multicosim.px4 sitl``: our PX4-compatible SITL on PX4's UDP ports.

    python -m multicosim.px4 sitl                       # real time, 14550 (GCS), 14540 (API)
    python -m multicosim.px4 sitl --speed 5 --fidelity medium

QGroundControl, MAVProxy (``--master udpin:127.0.0.1:14550``) or MAVSDK
(``udpin://0.0.0.0:14540``) connect and fly it as they would PX4 SITL. Ctrl-C stops it.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
import threading

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point (``multicosim px4 sitl`` delegates here)."""
    parser = argparse.ArgumentParser(prog="multicosim px4", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("sitl", help="run world + autopilot in real time on PX4's UDP ports")
    p.add_argument("--fidelity", choices=("low", "medium"), default="medium")
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="simulated seconds per wall second (PX4_SIM_SPEED_FACTOR)",
    )
    p.add_argument("--host", default="127.0.0.1", help="address the links bind and send to")
    p.add_argument(
        "--gcs-port",
        type=int,
        default=14550,
        help="ground-station port to send to (0: no ground-station link)",
    )
    p.add_argument(
        "--api-port", type=int, default=14540, help="API (MAVSDK) port to send to (0: no API link)"
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--duration", type=float, default=None, help="stop after this many sim s")
    p.add_argument("-v", "--verbose", action="store_true")
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    if not args.speed > 0:
        parser.error("--speed must be positive")
    from ._sitl import Link, run_sitl

    links = []
    if args.gcs_port:
        links.append(Link(args.gcs_port, 0, args.host))
    if args.api_port:
        links.append(Link(args.api_port, 0, args.host))
    if not links:
        parser.error("at least one of --gcs-port and --api-port is needed")
    stop = threading.Event()
    # SIGTERM ends the run as cleanly as Ctrl-C does.
    signal.signal(signal.SIGTERM, lambda *_: stop.set())

    def ready(ports: list[int]) -> None:
        print(f"multicosim px4 sitl ready: local ports {ports}", flush=True)

    with contextlib.suppress(KeyboardInterrupt):
        run_sitl(
            fidelity=args.fidelity,
            speed=args.speed,
            links=links,
            seed=args.seed,
            duration=args.duration,
            stop=stop,
            on_ready=ready,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
