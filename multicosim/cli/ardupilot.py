"""``multicosim ardupilot``: fly a QGroundControl plan, and the ArduPilot image's entry point.

    multicosim ardupilot sitl --plan mission.plan --params copter.csv \
        --firmware-dir ../shared/ardupilot-sitl --speed 20

flies the plan (its mission, geofence and rally points) on ArduCopter (or ArduRover) over our
MuJoCo world with multicosim's ground station and prints how it went.

    multicosim ardupilot launch --vehicle copter --sim-host 172.18.0.1 --mavlink-port 40001 \
        --home 47.397742,8.545594,488 --params '{"FRAME_TYPE": 1}'

writes ArduPilot's defaults file with ``--params`` in its working directory (/ardupilot)
and becomes ArduPilot (``/opt/ardupilot/bin/ardu<vehicle>``), whose JSON physics and MAVLink
link go to ``--sim-host`` (the simulation network's gateway, where the bridge listens).
"""

from __future__ import annotations

import argparse
import json
import os
import sys

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point (``multicosim ardupilot`` delegates here)."""
    from .common import add_plan_options, command_parser, run_command, subcommands

    parser = command_parser(
        "multicosim ardupilot",
        "ArduPilot tools: 'sitl' flies a QGroundControl plan on ArduPilot SITL over our world; "
        "'launch' is the ArduPilot image's entry point, which starts ArduPilot on the "
        "simulation's physics bridge.",
    )
    sub = subcommands(parser, "command")
    sitl = sub.add_parser(
        "sitl",
        help="fly a QGroundControl plan on ArduPilot SITL over the MuJoCo world",
        description="Fly a QGroundControl plan on ArduPilot SITL (real ArduCopter or "
        "ArduRover) over multicosim's MuJoCo world, paced at --speed; print the result.",
    )
    add_plan_options(sitl, required=True)
    sitl.add_argument(
        "--vehicle", choices=("copter", "rover"), default="copter", help="which ArduPilot flies"
    )
    sitl.add_argument(
        "--firmware-dir",
        default=os.environ.get("MCS_ARDUPILOT_DIR"),
        help="ArduPilot SITL's directory (bin/arducopter, params/); default: MCS_ARDUPILOT_DIR",
    )
    sitl.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    sitl.add_argument("--seed", type=int, default=0, help="fixes every random source")
    sitl.add_argument(
        "--duration", type=float, default=None, help="the mission's time limit (simulated s)"
    )
    sitl.add_argument("-v", "--verbose", action="store_true", help="show tracebacks")
    launch = sub.add_parser(
        "launch", help="(in the ArduPilot image) write ArduPilot's parameters and start it"
    )
    launch.add_argument(
        "--vehicle", choices=("copter", "rover"), required=True, help="which ArduPilot to start"
    )
    launch.add_argument("--sim-host", required=True, help="address of the physics bridge")
    launch.add_argument("--mavlink-port", type=int, required=True, help="the bridge's TCP port")
    launch.add_argument("--home", required=True, help="LAT,LON,ALT (degrees, m AMSL)")
    launch.add_argument("--params", default="{}", help="ArduPilot parameters, a JSON object")
    args = parser.parse_args(argv)
    if args.command == "sitl":
        if not args.speed > 0:
            parser.error("--speed must be positive")
        return run_command("multicosim ardupilot sitl", lambda: _sitl(args), verbose=args.verbose)
    from ..ardupilot.launch import exec_in_container
    from ..core.geo import Home

    try:
        lat, lon, alt = (float(v) for v in args.home.split(","))
        params = json.loads(args.params)
    except ValueError as exc:
        parser.error(f"--home or --params: {exc}")
    exec_in_container(
        vehicle=args.vehicle,
        sim_host=args.sim_host,
        mavlink_port=args.mavlink_port,
        home=Home(lat, lon, alt),
        params=params,
    )
    return 0  # not reached: the process became ArduPilot


def _sitl(args: argparse.Namespace) -> int:
    """Fly ``--plan`` on ArduPilot with multicosim's ground station."""
    import msgspec

    from .. import ardupilot
    from .common import fly_plan

    config = ardupilot.Configuration.from_plan(args.plan)
    if args.duration is not None:
        config = msgspec.structs.replace(config, time_limit=args.duration)
    params = ardupilot.read_params(args.params) if args.params else {}
    vehicle = ardupilot.ArduCopter if args.vehicle == "copter" else ardupilot.ArduRover
    simulator = vehicle(
        fidelity="medium",
        firmware_dir=args.firmware_dir,
        seed=args.seed,
        realtime=args.speed,
        params=params,
    )
    return fly_plan(simulator, config)


if __name__ == "__main__":
    sys.exit(main())
