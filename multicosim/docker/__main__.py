"""``python -m multicosim.docker build|sweep``: build the images, remove leftovers."""

from __future__ import annotations

import argparse
import logging
import sys

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    parser = argparse.ArgumentParser(prog="python -m multicosim.docker", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true", help="show build output")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("build", help="build multicosim's images locally (never pulls)")
    p.add_argument("--base", help="base image (default: python:3.11-slim or a Debian base)")
    p.add_argument("--force", action="store_true", help="rebuild even if up to date")
    p.add_argument(
        "--px4-dir",
        help="also build the real-PX4 image from this PX4 SITL directory (bin/px4 and etc/)",
    )
    p.add_argument(
        "--ardupilot-dir",
        help="also build the ArduPilot image from this ArduPilot SITL directory "
        "(bin/arducopter, bin/ardurover, params/)",
    )
    sub.add_parser("sweep", help="remove containers and networks of runs whose host is gone")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)

    if args.command == "build":
        from ._images import build

        progress = (lambda line: print(line, file=sys.stderr)) if args.verbose else None
        for tag in build(
            base=args.base,
            force=args.force,
            progress=progress,
            px4_dir=args.px4_dir,
            ardupilot_dir=args.ardupilot_dir,
        ):
            print(tag)
        return 0
    from ._sweep import sweep

    report = sweep()
    print(report.summary())
    return 0


if __name__ == "__main__":
    sys.exit(main())
