"""``--mcs-repeat=K``: every simulation test K times with one seed, proven the same each time.

A test of ours (one using multicosim's fixtures or the ``fidelity`` marker) runs K times, each
from a clean slate (its fixtures of every scope set up again), and passes only if every run
gave the same verdict and routed the same samples
([`multicosim.trace.fingerprint`][multicosim.trace.fingerprint]). A test that does not is failed,
naming the first sample that differs: its time, topic, field and both values (a component reading
the wall clock or an unseeded random source shows up there). Real firmware (PX4, ArduPilot) flies on
its own threads: its tests must repeat their verdict, and where their samples first parted is noted
in the JUnit property, not held against them. Only the last run's reports reach pytest's reporters;
each carries the fingerprint, so the JUnit report has the hash (``mcs_trace_hash``). With
``--mcs-repeat-load`` the plugin keeps busy processes running meanwhile. The summary says how many
tests were proven repeatable.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

# pytest's own protocol for one item (setup, call, teardown), which pytest supports running
# again on the same item (it re-creates the item's fixture request), as rerun plugins do.
from _pytest.runner import runtestprotocol

from multicosim.local.load import CpuLoad

from .activity import uses_ours
from .artifacts import artifacts_dir, dest_key, recording, trace_key
from .options import settings_key
from .reports import replay_command

__all__ = [
    "HASH_PROPERTY",
    "PLUGIN_NAME",
    "REPEAT_PROPERTY",
    "Repeater",
    "Tally",
    "fingerprint_key",
    "note_fingerprint",
    "repeats",
    "run_repeated",
    "wants_fingerprint",
]

PLUGIN_NAME = "multicosim-repeat"
"""The name the ``Repeater`` is registered under."""

HASH_PROPERTY = "mcs_trace_hash"
"""The JUnit property (``user_properties``) with the hash of every sample a test routed."""
REPEAT_PROPERTY = "mcs_repeat"
"""The JUnit property saying whether a repeated test proved repeatable."""

fingerprint_key = pytest.StashKey[Any]()
"""Where an item's stash keeps its last run's
[`multicosim.trace.Fingerprint`][multicosim.trace.Fingerprint]."""


@dataclasses.dataclass
class Tally:
    """Repeated tests, as the session's reports say (counted where the summary is written)."""

    proven: int = 0
    no_samples: int = 0
    verdict_only: int = 0
    differing: int = 0


def wants_fingerprint(config: pytest.Config) -> bool:
    """Whether tests' fingerprints are taken: repeats, or a JUnit report to carry them."""
    return config.stash[settings_key].repeat > 1 or bool(getattr(config.option, "xmlpath", None))


def note_fingerprint(item: pytest.Item) -> None:
    """Take the fingerprint of what ``item``'s call routed and put it in its properties."""
    test_trace = item.stash.get(trace_key, None)
    if test_trace is None or not test_trace.record:
        return
    # What teardown routes (stopping the simulations) is not part of the test's run.
    test_trace.detach()
    found = test_trace.fingerprint()
    item.stash[fingerprint_key] = found
    if found.samples:
        props = [p for p in item.user_properties if p[0] != HASH_PROPERTY]
        props.append((HASH_PROPERTY, found.digest))
        item.user_properties[:] = props


@dataclasses.dataclass
class _Run:
    reports: list[pytest.TestReport]
    fingerprint: Any
    trace: Any

    @property
    def verdict(self) -> tuple[tuple[str, str], ...]:
        return tuple((r.when, _outcome(r)) for r in self.reports)

    def said(self) -> str:
        failed = next((r for r in self.reports if r.failed), None)
        if failed is None:
            return "/".join(sorted({_outcome(r) for r in self.reports}))
        line = _first_line(failed)
        return f"failed in {failed.when}" + (f" ({line})" if line else "")


def _outcome(report: pytest.TestReport) -> str:
    return "xfailed" if hasattr(report, "wasxfail") else report.outcome


def _first_line(report: pytest.TestReport) -> str:
    crash = getattr(report.longrepr, "reprcrash", None)
    text = getattr(crash, "message", None) or str(report.longrepr or "")
    return text.strip().splitlines()[0][:200] if text.strip() else ""


def run_repeated(item: pytest.Item, nextitem: pytest.Item | None, runs: int) -> None:
    """Run ``item`` ``runs`` times and report once: its last run, or why the runs differ."""
    ihook = item.ihook
    ihook.pytest_runtest_logstart(nodeid=item.nodeid, location=item.location)
    done: list[_Run] = []
    for index in range(runs):
        last = index == runs - 1
        item.stash[fingerprint_key] = None
        with recording(item):
            # Torn down to the session between runs: a run must not inherit what an earlier
            # one left in a module's or the session's simulation.
            reports = runtestprotocol(item, nextitem=nextitem if last else None, log=False)
        done.append(
            _Run(reports, item.stash.get(fingerprint_key, None), item.stash.get(trace_key, None))
        )
    found = _compare(done)
    final = done[-1].reports
    target = next((r for r in final if r.when == "call"), None) or final[0]
    first = done[0].fingerprint
    if found is None and any(r.skipped and not hasattr(r, "wasxfail") for r in final):
        state = "skipped"  # the same skip every time proves nothing about the test
    elif found is None:
        state = f"repeatable: {runs} runs" + ("" if first and first.samples else " (no samples)")
        if first is not None and not first.deterministic:
            parted = _parted(done)
            state = f"same verdict in {runs} runs (real firmware: " + (
                f"samples first differ at {parted})" if parted else "same samples)"
            )
    else:
        state = "not repeatable"
        problem, number = found
        _fail(target, f"not repeatable over {runs} runs with one seed: {problem}")
        _explain(item, target, {1: done[0].trace, number: done[number - 1].trace})
    for report in final:
        report.user_properties = [p for p in report.user_properties if p[0] != REPEAT_PROPERTY]
        report.user_properties.append((REPEAT_PROPERTY, state))
        ihook.pytest_runtest_logreport(report=report)
    ihook.pytest_runtest_logfinish(nodeid=item.nodeid, location=item.location)


def _compare(done: list[_Run]) -> tuple[str, int] | None:
    """Why the runs differ and the number of the first run that differs from run 1."""
    first = done[0]
    for number, run in enumerate(done[1:], start=2):
        if run.verdict != first.verdict:
            return f"run 1 {first.said()}, run {number} {run.said()}", number
        a, b = first.fingerprint, run.fingerprint
        if a is not None and b is not None and a.deterministic and a != b:
            return (
                f"run {number} routed other samples than run 1 (hash {b.digest} != "
                f"{a.digest}); first difference: {a.first_difference(b)}"
            ), number
    return None


def _parted(done: list[_Run]) -> str | None:
    """Where real firmware's runs first parted (the earliest over the runs), if they did."""
    first = done[0].fingerprint
    found = [first.first_difference(r.fingerprint) for r in done[1:] if r.fingerprint]
    parted = [d for d in found if d is not None]
    return str(min(parted, key=lambda d: d.time)) if parted else None


def _explain(item: pytest.Item, report: pytest.TestReport, traces: dict[int, Any]) -> None:
    """Save the traces of the two runs that differ; add the report section that says where."""
    settings = item.config.stash[settings_key]
    replay = replay_command(settings, item)
    dest = item.stash.get(dest_key, None) or artifacts_dir(settings, item)
    lines = [f"verdict: {_first_line(report)}", f"replay: {replay}"]
    for number, test_trace in traces.items():
        if test_trace is None or not test_trace.recorders:
            continue
        try:
            saved = test_trace.save(dest / f"run-{number}", plot=False, replay=replay)
        except Exception as exc:  # a trace is a diagnosis aid: never turn a report into a crash
            lines.append(f"run {number}: trace not saved ({type(exc).__name__}: {exc})")
            continue
        lines.extend(f"run {number} {p.suffix.lstrip('.')}: {p}" for p in saved)
    report.sections = [s for s in report.sections if s[0] != "multicosim"]
    report.sections.append(("multicosim", "\n".join(lines)))


def _fail(report: pytest.TestReport, why: str) -> None:
    shown = str(report.longrepr) if report.failed and report.longrepr else ""
    report.outcome = "failed"
    report.longrepr = why + (f"\n\nthe last run's failure:\n{shown}" if shown else "")
    if hasattr(report, "wasxfail"):
        del report.wasxfail


class Repeater:
    """The plugin's part registered under ``--mcs-repeat``: runs, counts and sums up."""

    def __init__(self, config: pytest.Config) -> None:
        self.config = config
        self.settings = config.stash[settings_key]
        self.tally = Tally()
        self.load = CpuLoad(self.settings.repeat_load)

    def pytest_sessionstart(self, session: pytest.Session) -> None:
        # One load for the machine: under xdist the controller keeps it, not each worker.
        if self.settings.repeat_load and not hasattr(self.config, "workerinput"):
            self.load.start()

    def pytest_unconfigure(self) -> None:
        self.load.stop()

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_protocol(
        self, item: pytest.Item, nextitem: pytest.Item | None
    ) -> bool | None:
        runs = repeats(item)
        if runs <= 1:
            return None
        run_repeated(item, nextitem, runs)
        return True

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        # From the teardown report, once per test, wherever it ran (xdist's workers too).
        if report.when != "teardown":
            return
        state = dict(report.user_properties).get(REPEAT_PROPERTY)
        if state is None:
            return
        if state == "skipped":
            return
        if state == "not repeatable":
            self.tally.differing += 1
        elif str(state).startswith("same verdict"):
            self.tally.verdict_only += 1
        elif "no samples" in str(state):
            self.tally.no_samples += 1
        else:
            self.tally.proven += 1

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        line = self.summary()
        if line is not None:
            terminalreporter.write_line(line)

    def summary(self) -> str | None:
        """The summary line (None when no test repeated)."""
        counts = self.tally
        if not (counts.proven or counts.no_samples or counts.verdict_only or counts.differing):
            return None
        line = (
            f"multicosim: {counts.proven} test(s) proven repeatable "
            f"({self.settings.repeat} runs each with seed {self.settings.seed}: same verdict "
            f"and same samples)"
        )
        if self.settings.repeat_load:
            line += f" under {self.settings.repeat_load} busy processes"
        if counts.verdict_only:
            line += f", {counts.verdict_only} with real firmware with the same verdict"
        if counts.no_samples:
            line += f", {counts.no_samples} with the same verdict (no simulated samples)"
        if counts.differing:
            line += f", {counts.differing} not repeatable"
        return line


def repeats(item: pytest.Item) -> int:
    """How many times ``item`` runs (1 unless ``--mcs-repeat`` and it is a test of ours)."""
    runs = item.config.stash[settings_key].repeat
    return runs if runs > 1 and uses_ours(item) else 1
