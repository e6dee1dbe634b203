"""The ``multicosim`` command.

``multicosim serve MODULE:FIRMWARE --port N``   serve a firmware (component side)
``multicosim participant MODULE:FACTORY``        run a participant (component side)
``multicosim sweep``                             remove what killed runs left behind
``multicosim images build``                      build the container images locally
                                                 (``--fmu PATH``: an FMU's image too)
``multicosim plot TRACE.mcap``                   plot a trace to a PNG
``multicosim px4 sitl``                          PX4-compatible SITL on PX4's UDP ports
                                                 (``--plan FILE``: fly a QGroundControl plan)
``multicosim ardupilot sitl --plan FILE``        fly a QGroundControl plan on ArduPilot
``multicosim ardupilot launch``                  (in the ArduPilot image) start ArduPilot
"""

from __future__ import annotations

import argparse
import logging
import sys
from typing import Any

from ..runtime.serve import build_from_config, load_target
from .common import command_parser, run_command, subcommands

__all__ = ["main"]

DESCRIPTION = (
    "multicosim: run component programs (participants, firmware), build the container images, "
    "plot traces, remove what killed runs left behind, and run a PX4-compatible SITL."
)


def _load(target: str) -> Any:
    try:
        return load_target(target)
    except ValueError as exc:
        raise SystemExit(f"error: {exc}") from None


def _port(text: str) -> int:
    from ..runtime.serve import port_argument

    return port_argument(text)


def _serve(args: argparse.Namespace) -> int:
    from ..runtime.serve import Firmware, serve

    fw = _load(args.target)
    if not isinstance(fw, Firmware):
        raise SystemExit(f"error: {args.target} is not a firmware (use @multicosim.firmware)")
    serve(fw, port=args.port, host=args.host)
    return 0


def _participant(args: argparse.Namespace) -> int:
    from ..runtime.serve import run_participant

    run_participant(build_from_config(_load(args.target), args.config))
    return 0


def _sweep(args: argparse.Namespace) -> int:
    from ..local import sweep_stale_runs

    killed = sweep_stale_runs()
    print(f"removed {len(killed)} leftover process group(s)")
    try:
        from ..docker import sweep
    except ImportError:  # pragma: no cover - the docker subpackage always ships
        return 0
    print(f"docker: {sweep().summary()}")
    return 0


def _images_build(args: argparse.Namespace) -> int:
    from ..docker import build_images

    if args.fmu:  # a wrong path is refused before anything is built
        from ..fmi import describe

        for path in args.fmu:
            describe(path)
    progress = print if args.verbose else None
    tags = build_images(base=args.base, force=args.force, progress=progress)
    # Each vehicle builds its own firmware image, on the runtime image.
    if args.px4_dir is not None:
        from ..px4.image import build_image as build_px4

        tags.append(build_px4(args.px4_dir, force=args.force, progress=progress))
    if args.ardupilot_dir is not None:
        from ..ardupilot.image import build_image as build_ardupilot

        tags.append(build_ardupilot(args.ardupilot_dir, force=args.force, progress=progress))
    if args.fmu:
        from ..fmi import build_image

        for path in args.fmu:
            tags.append(build_image(path, compile=args.compile, force=args.force))
    for tag in tags:
        print(tag)
    return 0


def _plot(args: argparse.Namespace) -> int:
    from ..trace import plot_command

    result: int = plot_command(args.trace, args.output)
    return result


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``multicosim`` command."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["px4"]:
        # The PX4 tools own their options (``multicosim px4 sitl --speed 4 ...``).
        from .px4 import main as px4_main

        return px4_main(argv[1:])
    if argv[:1] == ["ardupilot"]:
        from .ardupilot import main as ardupilot_main

        return ardupilot_main(argv[1:])
    parser = command_parser("multicosim", DESCRIPTION)
    parser.add_argument(
        "-v", "--verbose", action="store_true", help="log debug messages; tracebacks on errors"
    )
    sub = subcommands(parser, "command")

    p = sub.add_parser("serve", help="serve a firmware until the simulation stops it")
    p.add_argument("target", help="MODULE:ATTRIBUTE of a @multicosim.firmware function")
    p.add_argument(
        "--port", type=_port, default=0, help="port to serve on: 1..65535, or 0 for any free port"
    )
    p.add_argument(
        "--host", default=None, help="address to bind (default: $MCS_BIND_HOST or 127.0.0.1)"
    )
    p.set_defaults(run=_serve)

    p = sub.add_parser("participant", help="run a participant stepped by the simulation")
    p.add_argument("target", help="MODULE:ATTRIBUTE of a participant factory")
    p.add_argument("--config", help="JSON configuration passed to the factory")
    p.set_defaults(run=_participant)

    p = sub.add_parser("sweep", help="remove processes and containers left by killed runs")
    p.set_defaults(run=_sweep)

    sub.add_parser("px4", help="PX4 tools: 'multicosim px4 sitl' runs a standalone SITL")
    sub.add_parser(
        "ardupilot",
        help="ArduPilot tools: 'multicosim ardupilot sitl --plan FILE' flies a plan; 'launch'",
    )

    p = sub.add_parser("plot", help="plot a trace: planned vs flown path, altitude, robustness")
    p.add_argument("trace", help="an MCAP trace written by multicosim")
    p.add_argument("-o", "--output", default=None, help="PNG to write (default: TRACE.png)")
    p.set_defaults(run=_plot)

    images = subcommands(sub.add_parser("images", help="container images"), "images_command")
    p = images.add_parser("build", help="build multicosim's images locally (never pulls)")
    p.add_argument("--force", action="store_true", help="rebuild even if up to date")
    p.add_argument(
        "--base",
        default=None,
        help="base image (default: python:3.11-slim if present, else a Debian base made "
        "with debootstrap)",
    )
    p.add_argument(
        "--px4-dir",
        default=None,
        help="also build the real-PX4 image from this PX4 SITL directory (bin/px4 and etc/)",
    )
    p.add_argument(
        "--ardupilot-dir",
        default=None,
        help="also build the ArduPilot image from this ArduPilot SITL directory "
        "(bin/arducopter, bin/ardurover, params/)",
    )
    p.add_argument(
        "--fmu",
        action="append",
        metavar="PATH",
        help="also build the image of this FMU (the runtime image with it in /opt/fmu); repeatable",
    )
    p.add_argument(
        "--compile",
        action="store_true",
        help="with --fmu: compile a binary from the FMU's C sources where it has none for Linux",
    )
    p.set_defaults(run=_images_build)

    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    return run_command("multicosim", lambda: int(args.run(args)), verbose=args.verbose)


if __name__ == "__main__":
    sys.exit(main())
