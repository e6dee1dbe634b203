"""``multicosim plot``: redraw a trace's plot from the command line."""

from __future__ import annotations

import sys
from pathlib import Path

from ..core.errors import ConfigurationError, DependencyMissingError, TraceError

__all__ = ["plot_command"]


def plot_command(trace: str, output: str | None = None) -> int:
    """``multicosim plot TRACE.mcap -o OUT.png``: write the plot, print its path.

    Returns 0, or 1 with the reason on stderr (no file, not an MCAP file, an MCAP file that
    multicosim did not write, nothing to plot, matplotlib missing).
    """
    target = Path(output) if output else Path(trace).with_suffix(".png")
    from ._plot import plot_trace

    try:
        written = plot_trace(trace, target)
    except (TraceError, ConfigurationError, DependencyMissingError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(written)
    return 0
