"""What every ``multicosim`` subcommand shares: help formatting and error reporting."""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Callable
from typing import Any

__all__ = [
    "HelpFormatter",
    "add_plan_options",
    "command_parser",
    "fly_plan",
    "run_command",
    "subcommands",
]


class HelpFormatter(argparse.HelpFormatter):
    """Help that names every option's default (where it has a meaningful one)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        meaningful = default is not None and default is not False and default != argparse.SUPPRESS
        if meaningful and "default" not in text:
            text += " (default: %(default)s)"
        return text


def command_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """An argument parser for one of multicosim's commands: its subcommands' help alike."""
    parser = argparse.ArgumentParser(
        prog=prog, description=description, formatter_class=HelpFormatter
    )
    return parser


def subcommands(parser: argparse.ArgumentParser, dest: str) -> Any:
    """The subcommands of ``parser``, each with the same help formatting."""
    parser_class: Any = functools.partial(argparse.ArgumentParser, formatter_class=HelpFormatter)
    return parser.add_subparsers(dest=dest, required=True, parser_class=parser_class)


def run_command(prog: str, run: Callable[[], int], *, verbose: bool = False) -> int:
    """Run a command; a multicosim error is one line on stderr and exit status 1.

    The traceback is for ``-v``: what went wrong and how to fix it is in the message.
    """
    from ..core.errors import MulticosimError

    try:
        return run()
    except MulticosimError as exc:
        if verbose:
            raise
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 1


def add_plan_options(parser: argparse.ArgumentParser, *, required: bool = False) -> None:
    """``--plan`` (a QGroundControl .plan to fly) and ``--params`` (a parameter file)."""
    parser.add_argument(
        "--plan",
        required=required,
        default=None,
        help="fly this QGroundControl .plan (its mission, geofence and rally points) with "
        "multicosim's ground station, print the result and exit (status 0 if it completed)",
    )
    parser.add_argument(
        "--params",
        default=None,
        help="a parameter file set at boot, before arming: 'param set NAME VALUE' lines, "
        "QGroundControl's .params or a name,value CSV",
    )


def fly_plan(simulator: Any, config: Any) -> int:
    """Fly ``config`` on ``simulator``, print how it went; 0 if the mission completed."""
    with simulator.start() as simulation:
        result = simulation.firmware.send(config)
    reached = ", ".join(f"{r.index} at {r.time:.1f} s" for r in result.reached) or "none"
    print(f"waypoints reached: {reached}")
    for text in result.messages:
        print(f"autopilot: {text}")
    if result.completed:
        print(f"mission completed in {result.duration:.1f} simulated seconds")
        return 0
    print(f"mission not completed: {result.reason}")
    return 1
