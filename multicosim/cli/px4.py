"""``multicosim px4 sitl``: a PX4 SITL on our MuJoCo world, on PX4's usual UDP ports.

    multicosim px4 sitl                                  # built-in autopilot, real time
    multicosim px4 sitl --speed 5 --fidelity medium
    multicosim px4 sitl --px4-binary ../shared/px4-sitl/bin/px4 --speed 10   # real PX4
    multicosim px4 sitl --plan mission.plan --params vehicle.params --speed 20
    multicosim px4 sitl --count 3                        # three vehicles in one world
    multicosim px4 sitl --count 2 --px4-binary ../shared/px4-sitl/bin/px4

QGroundControl (UDP 14550), MAVProxy (``--master udpin:127.0.0.1:14550``) or MAVSDK
(``udpin://0.0.0.0:14540``) connect and fly it as they would PX4 SITL with Gazebo. With
``--plan``, multicosim's own ground station flies a QGroundControl plan instead, and the
command ends with the flight. With ``--count N``, N vehicles share one world, each on the
ports PX4's multi-vehicle SITL gives instance i (MAVSDK on 14540 + i, MAV_SYS_ID i + 1,
every vehicle to QGroundControl on 14550), 3 m apart northwards as PX4's multi-vehicle
Gazebo script spawns them.
Ctrl-C or SIGTERM stops it and everything it started.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

if TYPE_CHECKING:
    from ..px4.sitl import SITL

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point (``multicosim px4 sitl`` delegates here)."""
    from .common import add_plan_options, command_parser, run_command, subcommands

    parser = command_parser(
        "multicosim px4",
        "A PX4 SITL on multicosim's MuJoCo world, on PX4's usual UDP ports: QGroundControl "
        "and MAVSDK connect and fly it as they would PX4 SITL with Gazebo.",
    )
    sub = subcommands(parser, "command")
    p = sub.add_parser(
        "sitl",
        help="run world + autopilot in real time on PX4's UDP ports",
        description="Run the world and an autopilot (the built-in one, or real PX4) in real "
        "time; ground stations connect on the ports it prints. Ctrl-C stops it.",
    )
    p.add_argument(
        "--fidelity",
        choices=("low", "medium"),
        default="medium",
        help="low: a point mass; medium: MuJoCo physics",
    )
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
    p.add_argument("--seed", type=int, default=0, help="fixes every random source")
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        help="stop after this many simulated seconds (default: run until Ctrl-C)",
    )
    p.add_argument(
        "--px4-binary",
        default=None,
        help="fly real PX4: its SITL binary (bin/px4, with etc/ beside bin/); PX4 keeps its "
        "own MAVLink ports (14550 GCS, 14540+instance API)",
    )
    p.add_argument(
        "--px4-image",
        default=None,
        help="fly real PX4 in a container of this image (multicosim images build --px4-dir)",
    )
    p.add_argument(
        "--count",
        type=int,
        default=1,
        help="vehicles in one world, each on PX4's ports for its instance (as PX4's "
        "multi-vehicle SITL; with --px4-binary, that many real PX4 instances)",
    )
    add_plan_options(p)
    p.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    launch = sub.add_parser(
        "launch", help="(in the PX4 image) prepare PX4's working directory and start PX4"
    )
    launch.add_argument("--instance", type=int, default=0, help="PX4's instance number")
    launch.add_argument("--sim-host", required=True, help="address of the simulator bridge")
    launch.add_argument(
        "--link",
        action="append",
        default=None,
        help="a MAVLink link LOCAL_PORT:HOST:PORT:MODE (repeat; none: PX4's own links)",
    )
    launch.add_argument("--model", default="none_iris", help="PX4's airframe")
    launch.add_argument("--params", default="{}", help="PX4 parameters as a JSON object")
    args = parser.parse_args(argv)
    if args.command == "launch":
        return _launch(parser, args)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    if not args.speed > 0:
        parser.error("--speed must be positive")
    from ..mavlink.udp import API_PORT, GCS_PORT

    if not args.count >= 1:
        parser.error(f"--count {args.count}: expected a number of vehicles, 1 or more")
    if args.count > 1:
        if args.plan:
            parser.error("--plan flies one vehicle; give --count 1 (or fly a fleet in Python)")
        if (args.gcs_port, args.api_port, args.host) != (GCS_PORT, API_PORT, "127.0.0.1"):
            parser.error(
                "--gcs-port, --api-port and --host set one vehicle's links; with --count "
                "each vehicle has PX4's ports for its instance"
            )
    if args.plan:
        return run_command("multicosim px4 sitl", lambda: _plan(args), verbose=args.verbose)
    stop = threading.Event()
    # SIGTERM ends the run as cleanly as Ctrl-C does.
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    if args.count > 1:
        return run_command(
            "multicosim px4 sitl", lambda: _fleet(parser, args, stop), verbose=args.verbose
        )
    if args.px4_binary or args.px4_image:
        return run_command("multicosim px4 sitl", lambda: _real(parser, args, stop))
    from ..mavlink.udp import Link
    from ..px4.standalone import run_sitl

    links = []
    if args.gcs_port:
        links.append(Link(args.gcs_port, 0, args.host))
    if args.api_port:
        links.append(Link(args.api_port, 0, args.host))
    if not links:
        parser.error("at least one of --gcs-port and --api-port is needed")

    def ready(ports: list[int]) -> None:
        # Where ground stations listen (what a user connects), not our links' own ports.
        where = []
        if args.gcs_port:
            where.append(f"QGroundControl on UDP {args.gcs_port}")
        if args.api_port:
            where.append(f"MAVSDK on udpin://0.0.0.0:{args.api_port}")
        print(f"multicosim px4 sitl ({args.fidelity}) ready: {', '.join(where)}", flush=True)

    def run() -> int:
        with contextlib.suppress(KeyboardInterrupt):
            run_sitl(
                fidelity=args.fidelity,
                params=_params(args),
                speed=args.speed,
                links=links,
                seed=args.seed,
                duration=args.duration,
                stop=stop,
                on_ready=ready,
            )
        return 0

    return run_command("multicosim px4 sitl", run, verbose=args.verbose)


def _real(parser: argparse.ArgumentParser, args: argparse.Namespace, stop: threading.Event) -> int:
    from ..mavlink.udp import API_PORT, GCS_PORT
    from ..px4.standalone import run_real_sitl

    sitl = _sitl(parser, args)
    assert sitl is not None

    def ready(instance: int, run_dir: Path) -> None:
        print(
            f"real PX4 SITL instance {instance} is flying the MuJoCo world: QGroundControl on "
            f"UDP {GCS_PORT}, MAVSDK on udpin://0.0.0.0:{API_PORT + instance} (logs: {run_dir})",
            flush=True,
        )

    with contextlib.suppress(KeyboardInterrupt):
        run_real_sitl(
            sitl,
            params=_params(args),
            speed=args.speed,
            seed=args.seed,
            duration=args.duration,
            stop=stop,
            on_ready=ready,
        )
    return 0


def _sitl(parser: argparse.ArgumentParser, args: argparse.Namespace) -> SITL | None:
    """Real PX4 as the options name it (None: the built-in autopilot)."""
    from ..core.errors import ConfigurationError
    from ..px4.sitl import SITL

    if not (args.px4_binary or args.px4_image):
        return None
    try:
        return SITL(binary=args.px4_binary, image=None if args.px4_binary else args.px4_image)
    except ConfigurationError as exc:
        parser.error(str(exc))


def _fleet(parser: argparse.ArgumentParser, args: argparse.Namespace, stop: threading.Event) -> int:
    """``--count N``: N vehicles in one world, each a PX4 instance on its own ports."""
    from ..fleet import Fleet, PX4Vehicle
    from ..mavlink.udp import API_PORT, GCS_PORT
    from ..physics import Pose
    from ..px4.standalone import run_until

    firmware = _sitl(parser, args)
    vehicle_params = _params(args)
    simulator = Fleet(
        {
            f"iris_{i}": PX4Vehicle(
                start=Pose(north=3.0 * i), firmware=firmware, params=vehicle_params, own_links=True
            )
            for i in range(args.count)
        },
        fidelity=args.fidelity,
        # Only an image: PX4 runs in containers of it.
        placement="docker" if firmware is not None and firmware.binary is None else None,
        seed=args.seed,
        realtime=args.speed,
    )
    with simulator.start() as simulation:
        for name, node in simulation.vehicles.items():
            print(
                f"{name}: PX4 instance {node.instance} (MAV_SYS_ID {node.instance + 1}), "
                f"MAVSDK on udpin://0.0.0.0:{API_PORT + node.instance}",
                flush=True,
            )
        kind = "real PX4" if firmware is not None else args.fidelity
        print(
            f"multicosim px4 sitl ({kind}) ready: {args.count} vehicles, QGroundControl on "
            f"UDP {GCS_PORT} (logs: {simulation.run_dir})",
            flush=True,
        )
        with contextlib.suppress(KeyboardInterrupt):
            run_until(simulation, args.duration, stop)
    return 0


def _params(args: argparse.Namespace) -> dict[str, float]:
    from ..mavlink.params import read_params

    return read_params(args.params) if args.params else {}


def _plan(args: argparse.Namespace) -> int:
    """Fly ``--plan`` with multicosim's ground station, paced at ``--speed``."""
    from .. import px4
    from .common import fly_plan

    config = px4.Configuration.from_plan(args.plan)
    if args.duration is not None:
        config = msgspec.structs.replace(config, time_limit=args.duration)
    firmware = None
    if args.px4_binary or args.px4_image:
        firmware = px4.SITL(
            binary=args.px4_binary, image=None if args.px4_binary else args.px4_image
        )
    simulator = px4.PX4(
        fidelity=args.fidelity,
        # Only an image: PX4 runs in a container of it.
        placement="docker" if firmware is not None and firmware.binary is None else None,
        seed=args.seed,
        realtime=args.speed,
        params=_params(args),
        firmware=firmware,
    )
    return fly_plan(simulator, config)


def _launch(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    import json

    from ..px4.sitl import MavlinkLink, exec_in_container

    try:
        links = [MavlinkLink.parse(text) for text in args.link] if args.link else None
    except ValueError:
        parser.error(f"--link {args.link!r}: expected LOCAL_PORT:HOST:PORT:MODE")
    exec_in_container(
        instance=args.instance,
        sim_host=args.sim_host,
        links=links,
        params=json.loads(args.params),
        model=args.model,
    )
    return 0  # not reached: the process became PX4


if __name__ == "__main__":
    sys.exit(main())
