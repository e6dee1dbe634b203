"""Agreement: each case of PX4's suite has one outcome on the built-in autopilot and real PX4.

A case flown on both (parametrized over ``autopilot``, in a module that declares
``KNOWN_DIFFERENCES``) notes its outcome in its report, so that the run which judges sees every
case's outcomes, whichever xdist worker flew them. The run fails where the outcomes differ,
unless the module lists the case as a known difference (with the PX4 v1.15 source that
explains it) or as an open one (measured, its cause not yet found: listed, not forgotten).
``tests/conftest.py`` registers it for the whole suite; xdist's controller collects nothing, so
a conftest beside the suite would not run there.
"""

from __future__ import annotations

from collections.abc import Generator
from typing import Any, cast

import pytest

__all__ = ["Agreement"]

_OUTCOME = "px4-agreement"


class Agreement:
    """The plugin: notes outcomes in reports, compares them where the reports arrive."""

    def __init__(self) -> None:
        # case -> autopilot -> "pass" / "fail"; "_known" / "_open" -> why it may differ
        self.seen: dict[str, dict[str, str]] = {}

    @pytest.hookimpl(wrapper=True)
    def pytest_runtest_makereport(
        self, item: pytest.Item, call: pytest.CallInfo[None]
    ) -> Generator[None, pytest.TestReport, pytest.TestReport]:
        """Note the outcome of a case flown on an ``autopilot`` (an expected failure fails)."""
        report = yield
        callspec = getattr(item, "callspec", None)
        autopilot = callspec.params.get("autopilot") if callspec is not None else None
        module: Any = getattr(item, "module", None)
        if autopilot is None or not hasattr(module, "KNOWN_DIFFERENCES"):
            return report
        if report.when == "call" or (report.when == "setup" and report.outcome != "passed"):
            xfailed = report.outcome == "skipped" and hasattr(report, "wasxfail")
            if report.outcome == "skipped" and not xfailed:
                return report  # not flown (no PX4 binary): nothing to compare
            failed = report.outcome == "failed" or xfailed
            case = getattr(item, "originalname", item.name)
            known = module.KNOWN_DIFFERENCES.get(case, "")
            open_ = getattr(module, "OPEN_DIFFERENCES", {}).get(case, "")
            outcome = [case, str(autopilot), "fail" if failed else "pass", known, open_]
            report.user_properties.append((_OUTCOME, outcome))
        return report

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        for name, value in report.user_properties:
            if name == _OUTCOME:
                case, autopilot, outcome, known, open_ = cast(list[str], value)
                seen = self.seen.setdefault(case, {})
                seen[autopilot] = outcome
                seen["_known"], seen["_open"] = known, open_

    def disagreements(self) -> list[str]:
        """The cases flown on both whose outcomes differ without a reason listed."""
        out = []
        for case, seen in sorted(self.seen.items()):
            both = {"builtin", "sitl"} <= seen.keys()
            differ = both and seen["builtin"] != seen["sitl"]
            if differ and not seen["_known"] and not seen["_open"]:
                out.append(f"{case}: built-in {seen['builtin']}, real PX4 {seen['sitl']}")
        return out

    def pytest_sessionfinish(self, session: pytest.Session, exitstatus: int) -> None:
        if hasattr(session.config, "workerinput"):
            return  # a worker sees only its own cases: the controller judges
        if self.disagreements() and exitstatus == pytest.ExitCode.OK:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED

    def pytest_terminal_summary(
        self, terminalreporter: Any, exitstatus: int, config: pytest.Config
    ) -> None:
        seen = {c: s for c, s in self.seen.items() if "sitl" in s}
        if not seen or hasattr(config, "workerinput"):
            return
        terminalreporter.section("built-in autopilot vs real PX4")
        for case, s in sorted(seen.items()):
            why = ""
            if s.get("builtin") not in (None, s["sitl"]):
                why = f" (known: {s['_known']})" if s["_known"] else ""
                why = why or (f" (open: {s['_open']})" if s["_open"] else "")
            builtin = s.get("builtin", "-")
            terminalreporter.line(f"{case}: built-in {builtin}, real PX4 {s['sitl']}{why}")
        for line in self.disagreements():
            terminalreporter.line(f"DISAGREE {line}", red=True)
