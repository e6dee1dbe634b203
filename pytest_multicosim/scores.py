"""The session's summary of the flights scored as the UAV test competition scores them.

At the end of a session that flew any (the competition's case files, ``competition``,
or our cases with ``score: competition``), the terminal summary lists each flight's verdict,
minimum distance, points, simulated and wall time, and how many cases an hour this machine
flies at each level, beside what the competition's evaluation allows one case:
[`TIMEOUT`][multicosim.px4.competition.TIMEOUT] seconds of real time. The figures come from the
tests' properties and pytest's own durations (setup, call and teardown: starting and
stopping the simulation count): a measurement, never a verdict.
"""

from __future__ import annotations

import collections
import math
from typing import Any

import pytest

__all__ = ["PLUGIN_NAME", "Tally"]

PLUGIN_NAME = "multicosim-competition-scores"
"""The name the session's ``Tally`` is registered under."""


class Tally:
    """Sums up the flights scored as the competition scores them (a plugin of the session)."""

    def __init__(self) -> None:
        self.wall: dict[str, float] = collections.defaultdict(float)
        self.scored: dict[str, dict[str, str]] = {}

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        # Setup starts the simulation and teardown stops it: one flight's wall time is all three.
        self.wall[report.nodeid] += report.duration
        found = {name: str(value) for name, value in report.user_properties}
        if report.when == "teardown" and "competition_point" in found:
            self.scored[report.nodeid] = found

    def lines(self) -> list[str]:
        """The summary: a line per flight, then cases an hour at each level."""
        from multicosim.px4.competition import TIMEOUT

        out = [
            f"{'case':<56} {'verdict':<10} {'min_dist':>8} {'point':>5} {'sim s':>7} {'wall s':>7}"
        ]
        groups: dict[str, list[tuple[float, float]]] = collections.defaultdict(list)
        for nodeid, found in self.scored.items():
            simulated, wall = float(found["mcs_simulated_s"]), self.wall[nodeid]
            level = nodeid.rpartition("[")[2].rstrip("]") if nodeid.endswith("]") else "-"
            groups[level].append((simulated, wall))
            out.append(
                f"{nodeid.rpartition('/')[2][-56:]:<56} {found['competition_verdict']:<10} "
                f"{float(found['competition_min_dist']):>8.2f} {found['competition_point']:>5} "
                f"{simulated:>7.1f} {wall:>7.1f}"
            )
        for level, flights in sorted(groups.items()):
            simulated = sum(s for s, _ in flights)
            wall = sum(w for _, w in flights)
            rate = 3600 * len(flights) / wall if wall > 0 else math.inf
            out.append(
                f"{level}: {len(flights)} flight(s), {simulated:.0f} s simulated in {wall:.1f} s: "
                f"{rate:.0f} cases an hour on this machine, {simulated / max(wall, 1e-9):.0f}x "
                f"real time; the competition runs a case in real time, within {TIMEOUT:g} s "
                f"({3600 / TIMEOUT:.1f} an hour at its limit, "
                f"{3600 * len(flights) / max(simulated, 1e-9):.0f} at these flights' length)"
            )
        return out

    def pytest_terminal_summary(self, terminalreporter: Any) -> None:
        if self.scored:
            terminalreporter.write_sep("=", "multicosim: the UAV test competition's scores")
            for line in self.lines():
                terminalreporter.write_line(line)
