"""``multicosim ardupilot launch``: the ArduPilot image's entry point.

    multicosim ardupilot launch --vehicle copter --sim-host 172.18.0.1 --mavlink-port 40001 \
        --home 47.397742,8.545594,488 --params '{"FRAME_TYPE": 1}'

writes ArduPilot's defaults file with ``--params`` in its working directory (/ardupilot)
and becomes ArduPilot (``/opt/ardupilot/bin/ardu<vehicle>``), whose JSON physics and MAVLink
link go to ``--sim-host`` (the simulation network's gateway, where the bridge listens).
"""

from __future__ import annotations

import json
import sys

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point (``multicosim ardupilot`` delegates here)."""
    from .common import command_parser, subcommands

    parser = command_parser(
        "multicosim ardupilot",
        "ArduPilot tools: 'launch' is the ArduPilot image's entry point, which starts "
        "ArduPilot on the simulation's physics bridge.",
    )
    sub = subcommands(parser, "command")
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


if __name__ == "__main__":
    sys.exit(main())
