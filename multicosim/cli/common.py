"""What every ``multicosim`` subcommand shares: help formatting and error reporting."""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["HelpFormatter", "command_parser", "run_command", "subcommands"]


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
