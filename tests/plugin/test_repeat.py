"""``--mcs-repeat``: a simulation test run K times with one seed, proven the same each time.

A deterministic test is proven repeatable (summary line, JUnit properties with its hash); a
component that reads the wall clock or an unseeded random source fails its test, which names
the first sample that differs (time, topic, field, both values); a verdict that changes
fails too; tests that are not ours run once.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest
from mcs_programs import process_gone

from multicosim.trace import read_trace

SOURCES = """
import random
import time
from pathlib import Path

import pytest

import multicosim as mcs
from multicosim import testing


class Reading:
    \"\"\"Publishes what READ gives each step: a sensor of the test's own making.\"\"\"

    period = 0.01

    def setup(self, ctx):
        pass

    def step(self, ctx):
        ctx.publish("reading", testing.CartState(x=READ(), noise=0.0))


def fly(mcs_simulator, read):
    global READ
    READ = read
    mcs_simulator.add(mcs.InProcessComponent(lambda: testing.Cart(noise=0.1), name="cart"))
    mcs_simulator.add(mcs.InProcessComponent(Reading, name="sensor"))
    firmware = mcs_simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    simulation = mcs_simulator.start()
    return simulation.get(firmware).send(testing.Drive(speed=1.0, steps=30))


def test_seeded(mcs_simulator):
    assert fly(mcs_simulator, lambda: 1.0).positions[-1] > 0


def test_wall_clock(mcs_simulator):
    assert fly(mcs_simulator, time.time).positions[-1] > 0


def test_unseeded_random(mcs_simulator):
    assert fly(mcs_simulator, random.random).positions[-1] > 0


def test_verdict_changes(mcs_simulator):
    runs = Path("runs")
    runs.write_text(runs.read_text() + "x" if runs.exists() else "x")
    fly(mcs_simulator, lambda: 1.0)
    assert len(runs.read_text()) != 2, "the second run fails"


def test_skipped(mcs_simulator):
    pytest.skip("nothing to fly here")


def test_not_ours():
    counted = Path("plain")
    counted.write_text(counted.read_text() + "x" if counted.exists() else "x")
"""


@pytest.fixture
def result(pytester: pytest.Pytester) -> pytest.RunResult:
    pytester.makepyfile(test_sources=SOURCES)
    return pytester.runpytest("--mcs-repeat=3", "--junitxml=report.xml", "-rf")


def test_a_deterministic_test_is_proven_repeatable(
    pytester: pytest.Pytester, result: pytest.RunResult
) -> None:
    result.assert_outcomes(passed=2, failed=3, skipped=1)
    result.stdout.fnmatch_lines(
        [
            "multicosim: 1 test(s) proven repeatable (3 runs each with seed 0: same verdict and "
            "same samples), 3 not repeatable"
        ]
    )
    # The JUnit report carries each test's hash, the same hash in every run.
    cases = {c.get("name"): c for c in ET.parse(pytester.path / "report.xml").iter("testcase")}
    props = {p.get("name"): p.get("value") for p in cases["test_seeded[low]"].iter("property")}
    assert re.fullmatch(r"[0-9a-f]{32}", props["mcs_trace_hash"] or "")
    assert props["mcs_repeat"] == "repeatable: 3 runs"
    assert not list(cases["test_not_ours"].iter("property"))
    # A test of no simulation runs once.
    assert (pytester.path / "plain").read_text() == "x"


@pytest.mark.parametrize("test", ["test_wall_clock", "test_unseeded_random"])
def test_a_test_reading_an_unseeded_source_fails_naming_the_first_differing_sample(
    result: pytest.RunResult, test: str
) -> None:
    text = result.stdout.str()
    section = text[text.index(f"_ {test}[low] _") :]
    # The first sample of the sensor's topic, its field, both values.
    match = re.search(
        r"not repeatable over 3 runs with one seed: run 2 routed other samples than run 1 "
        r"\(hash [0-9a-f]{32} != [0-9a-f]{32}\); first difference: t=(\S+) s, topic 'reading', "
        r"field 'x': (\S+) != (\S+)",
        section,
    )
    assert match is not None, section[:2000]
    assert float(match[1]) < 0.05  # the very first reading
    assert match[2] != match[3]


def test_a_changing_verdict_fails(result: pytest.RunResult) -> None:
    result.stdout.fnmatch_lines(
        [
            "*not repeatable over 3 runs with one seed: run 1 passed, run 2 failed in call "
            "(AssertionError: the second run fails*"
        ]
    )


def test_a_run_that_differs_keeps_both_traces_and_replays_with_the_repeat(
    pytester: pytest.Pytester, result: pytest.RunResult
) -> None:
    result.stdout.fnmatch_lines(["replay: *test_wall_clock* --mcs-repeat=3*"])
    test_dir = pytester.path / "mcs-artifacts" / "test_sources.py_test_wall_clock_low"
    kept = test_dir / "seed-0-in-process"
    traces = [read_trace(kept / f"run-{n}" / "trace.mcap") for n in (1, 2)]
    readings = [[m.data["x"] for m in trace.topic("reading")] for trace in traces]
    assert len(readings[0]) == len(readings[1]) > 0
    assert readings[0][0] != readings[1][0]


def test_load_runs_while_tests_repeat_and_stops_after(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_load="""
        import os
        import subprocess
        from pathlib import Path

        def test_under_load(mcs_simulator):
            out = subprocess.run(
                ["ps", "-o", "pid=,ppid=,args=", "--ppid", str(os.getpid())],
                capture_output=True, text=True,
            ).stdout
            busy = [line.split()[0] for line in out.splitlines() if "while True: pass" in line]
            Path("busy").write_text(" ".join(busy))
            assert len(busy) == 3
        """
    )
    result = pytester.runpytest("--mcs-repeat=2", "--mcs-repeat-load=3")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["*proven repeatable (2 runs each * under 3 busy processes*"])
    pids = [int(pid) for pid in (pytester.path / "busy").read_text().split()]
    assert len(pids) == 3
    assert all(process_gone(pid) for pid in pids)
