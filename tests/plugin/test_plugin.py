"""The pytest plugin, tested through ``pytester`` with real component processes."""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcs_programs import process_gone
from plugin_helpers import write_ini

from multicosim.core.fidelity import FIDELITIES
from multicosim.placement import placement_names
from pytest_multicosim.options import KEEP_TRACES
from pytest_multicosim.px4 import RealPX4

PYTEST = f"{shlex.quote(sys.executable)} -m pytest"
"""How a replay command names pytest: through the interpreter that ran the session."""

# -- options and their ini twins ------------------------------------------------------------

SETTINGS_PROBE = """
import json

def test_probe(mcs_settings, mcs_seed, pytestconfig):
    seen = {
        "fidelity": list(mcs_settings.fidelity),
        "placement": mcs_settings.placement,
        "seed": mcs_seed,
        "artifacts": str(mcs_settings.artifacts),
        "keep_traces": mcs_settings.keep_traces,
    }
    (pytestconfig.rootpath / "seen.json").write_text(json.dumps(seen))
"""


def probe(pytester: pytest.Pytester, *args: str) -> dict[str, object]:
    """Run the settings probe with ``args``; return what the fixtures saw."""
    pytester.makepyfile(test_probe=SETTINGS_PROBE)
    result = pytester.runpytest(*args)
    result.assert_outcomes(passed=1)
    seen: dict[str, object] = json.loads((pytester.path / "seen.json").read_text())
    return seen


def test_defaults(pytester: pytest.Pytester) -> None:
    seen = probe(pytester)
    assert seen == {
        "fidelity": ["low"],
        "placement": None,
        "seed": 0,
        "artifacts": str(pytester.path / "mcs-artifacts"),
        "keep_traces": "failed",
    }


OPTION_CASES = [
    # (option, value, field, expected value seen by the fixtures)
    ("mcs_fidelity", "medium", "fidelity", ["medium"]),
    ("mcs_fidelity", "high, low,high", "fidelity", ["high", "low"]),
    ("mcs_placement", "docker", "placement", "docker"),
    ("mcs_placement", "process", "placement", "process"),
    ("mcs_seed", "12345", "seed", 12345),
    ("mcs_keep_traces", "all", "keep_traces", "all"),
    ("mcs_keep_traces", "none", "keep_traces", "none"),
]


@pytest.mark.parametrize(("name", "value", "field", "expected"), OPTION_CASES)
@pytest.mark.parametrize("where", ["cli", "ini"])
def test_option_and_ini_twin(
    pytester: pytest.Pytester, where: str, name: str, value: str, field: str, expected: object
) -> None:
    if where == "cli":
        seen = probe(pytester, f"--{name.replace('_', '-')}={value}")
    else:
        write_ini(pytester, **{name: value})
        seen = probe(pytester)
    assert seen[field] == expected


def test_command_line_wins_over_ini(pytester: pytest.Pytester) -> None:
    write_ini(
        pytester,
        mcs_fidelity="high",
        mcs_placement="docker",
        mcs_seed="5",
        mcs_keep_traces="none",
        mcs_artifacts="from-ini",
    )
    assert probe(pytester)["seed"] == 5
    seen = probe(
        pytester,
        "--mcs-fidelity=low",
        "--mcs-placement=process",
        "--mcs-seed=6",
        "--mcs-keep-traces=all",
        "--mcs-artifacts=from-cli",
    )
    assert seen == {
        "fidelity": ["low"],
        "placement": "process",
        "seed": 6,
        "artifacts": str(pytester.path / "from-cli"),
        "keep_traces": "all",
    }


def test_artifacts_paths(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    # Like pytest's own paths: relative to the invocation directory on the command line,
    # relative to the ini file in the ini file; absolute paths are kept.
    sub = pytester.mkdir("sub")
    pytester.makepyfile(test_probe=SETTINGS_PROBE)
    monkeypatch.chdir(sub)
    pytester.runpytest("--mcs-artifacts=out", str(pytester.path)).assert_outcomes(passed=1)
    seen = json.loads((pytester.path / "seen.json").read_text())
    assert seen["artifacts"] == str(sub / "out")

    write_ini(pytester, mcs_artifacts="traces")
    pytester.runpytest(str(pytester.path)).assert_outcomes(passed=1)
    seen = json.loads((pytester.path / "seen.json").read_text())
    assert seen["artifacts"] == str(pytester.path / "traces")

    pytester.runpytest(f"--mcs-artifacts={tmp_path}", str(pytester.path)).assert_outcomes(passed=1)
    seen = json.loads((pytester.path / "seen.json").read_text())
    assert seen["artifacts"] == str(tmp_path)


BAD_VALUES = [
    # (option, bad value, what the error says is allowed)
    ("mcs_fidelity", "ultra", "allowed: low, medium, high (or a comma list of them)"),
    ("mcs_fidelity", "low,meduim", "allowed: low, medium, high (or a comma list of them)"),
    ("mcs_fidelity", ",", "allowed: low, medium, high (or a comma list of them)"),
    ("mcs_fidelity", "low,,medium", "allowed: low, medium, high (or a comma list of them)"),
    ("mcs_fidelity", "low,", "allowed: low, medium, high (or a comma list of them)"),
    (
        "mcs_placement",
        "kubernetes",
        f"allowed: {', '.join(placement_names())} (the 'multicosim.placements' entry points)",
    ),
    ("mcs_seed", "-1", "allowed: a non-negative integer"),
    ("mcs_seed", "lucky", "allowed: a non-negative integer"),
    ("mcs_keep_traces", "some", "allowed: failed, all, none"),
    ("mcs_repeat", "0", "allowed: an integer >= 1"),
    ("mcs_repeat", "twice", "allowed: an integer >= 1"),
    ("mcs_repeat_load", "-2", "allowed: an integer >= 0"),
]


@pytest.mark.parametrize(("name", "value", "allowed"), BAD_VALUES)
@pytest.mark.parametrize("where", ["cli", "ini"])
def test_bad_value_is_a_usage_error(
    pytester: pytest.Pytester, where: str, name: str, value: str, allowed: str
) -> None:
    pytester.makepyfile(test_nothing="def test_nothing(): pass")
    if where == "cli":
        result = pytester.runpytest(f"--{name.replace('_', '-')}={value}")
        source = f"--{name.replace('_', '-')}"
    else:
        write_ini(pytester, **{name: value})
        result = pytester.runpytest()
        source = f"{name} (in pytest.ini)"
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines([f"ERROR: {source}: {value.strip()!r} *; {allowed}"])
    if name == "mcs_fidelity":
        bad = next(item for item in value.split(",") if item not in FIDELITIES)
        # The misspelt level, or the empty item, is named.
        assert (f"'{bad}'" if bad else "an empty item") in result.stderr.str()
    assert "Traceback" not in result.stderr.str() + result.stdout.str()


def test_allowed_values_match_the_help(pytester: pytest.Pytester) -> None:
    result = pytester.runpytest("--help")
    result.stdout.fnmatch_lines(
        [
            "multicosim co-simulation:",
            "*--mcs-fidelity=MCS_FIDELITY*",
            "*--mcs-placement=MCS_PLACEMENT*",
            "*--mcs-seed=MCS_SEED*",
            "*--mcs-artifacts=MCS_ARTIFACTS*",
            "*--mcs-keep-traces=MCS_KEEP_TRACES*",
        ]
    )
    for name in ("mcs_fidelity", "mcs_placement", "mcs_seed", "mcs_artifacts", "mcs_keep_traces"):
        result.stdout.fnmatch_lines([f"  {name} (string)*"])
    text = result.stdout.str()
    placements = ("in-process", "process", "docker")
    assert all(level in text for level in FIDELITIES + placements + KEEP_TRACES)


def test_report_header(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_nothing="def test_nothing(): pass")
    result = pytester.runpytest("--mcs-fidelity=low,high", "--mcs-seed=99")
    result.stdout.fnmatch_lines(
        [
            "multicosim: fidelity=low,high placement=default seed=99 keep-traces=failed "
            f"artifacts={pytester.path / 'mcs-artifacts'}",
        ]
    )
    result.assert_outcomes(passed=1)


# -- the fidelity marker --------------------------------------------------------------------

MARKED = """
import pytest

@pytest.mark.fidelity("medium", "high")
def test_detailed(mcs_fidelity):
    assert mcs_fidelity in ("medium", "high")

@pytest.mark.fidelity("low")
def test_cheap(request):
    # The marker alone parametrizes the test, without asking for the fixture.
    assert request.node.callspec.params["mcs_fidelity"] == "low"

def test_aware(mcs_fidelity):
    assert mcs_fidelity in ("low", "medium", "high")

@pytest.fixture
def world(mcs_fidelity):
    return f"world@{mcs_fidelity}"

def test_through_a_fixture(world):
    assert world.startswith("world@")

def test_unaware(request):
    assert not hasattr(request.node, "callspec")
"""


def test_marker_deselects_unlisted_levels(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_marked=MARKED)
    result = pytester.runpytest("--mcs-fidelity=low", "-v", "-rs")
    # A level a test never runs at is no skip: a skip means something the test needed was
    # missing.
    result.assert_outcomes(passed=4, deselected=1)
    result.stdout.fnmatch_lines_random(
        [
            "*collected 5 items / 1 deselected / 4 selected",
            "multicosim: 1 deselected at fidelity levels they never run at",
            "*test_cheap?low? PASSED*",
            "*test_aware?low? PASSED*",
            "*test_through_a_fixture?low? PASSED*",
            "*test_unaware PASSED*",
        ]
    )
    assert "test_detailed" not in result.stdout.str()
    assert "SKIPPED" not in result.stdout.str()


def test_comma_list_runs_once_per_level_with_ids(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_marked=MARKED)
    result = pytester.runpytest("--mcs-fidelity=low,medium,high", "-v", "-rs")
    # detailed: 2 run + 1 deselected; cheap: 1 + 2; aware and fixture: 3 each; unaware: 1.
    result.assert_outcomes(passed=10, deselected=3)
    result.stdout.fnmatch_lines_random(
        [
            "multicosim: 3 deselected at fidelity levels they never run at",
            "*test_detailed?medium? PASSED*",
            "*test_detailed?high? PASSED*",
            "*test_cheap?low? PASSED*",
            "*test_aware?low? PASSED*",
            "*test_aware?medium? PASSED*",
            "*test_aware?high? PASSED*",
            "*test_through_a_fixture?high? PASSED*",
        ]
    )
    for gone in ("test_detailed[low]", "test_cheap[medium]", "test_cheap[high]"):
        assert gone not in result.stdout.str()


def test_only_selected_levels_run(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_marked=MARKED)
    result = pytester.runpytest("--mcs-fidelity=high", "-v")
    result.assert_outcomes(passed=4, deselected=1)
    assert "[low]" not in result.stdout.str()
    assert "[medium]" not in result.stdout.str()


def test_simulator_fixture_puts_the_level_in_the_id(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_sim="""
        def test_with_simulator(mcs_simulator, mcs_fidelity):
            assert mcs_fidelity in ("low", "medium")
        """
    )
    result = pytester.runpytest("--mcs-fidelity=low,medium", "-v")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines_random(
        ["*test_with_simulator?low? PASSED*", "*test_with_simulator?medium? PASSED*"]
    )


def test_marker_on_module_and_class(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_scoped="""
        import pytest

        pytestmark = pytest.mark.fidelity("high")

        def test_module_level():
            pass

        @pytest.mark.fidelity("low", "high")
        class TestBoth:
            def test_in_class(self, mcs_fidelity):
                assert mcs_fidelity in ("low", "high")

            @pytest.mark.fidelity("medium")
            def test_closest_marker_wins(self, mcs_fidelity):
                assert mcs_fidelity == "medium"
        """
    )
    result = pytester.runpytest("--mcs-fidelity=low,medium", "-v")
    result.assert_outcomes(passed=2, deselected=4)
    result.stdout.fnmatch_lines_random(
        ["*test_in_class?low? PASSED*", "*test_closest_marker_wins?medium? PASSED*"]
    )
    assert "test_module_level" not in result.stdout.str()


def test_marker_is_registered(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_marked=MARKED)
    result = pytester.runpytest("--strict-markers", "-W", "error")
    result.assert_outcomes(passed=4, deselected=1)
    pytester.runpytest("--markers").stdout.fnmatch_lines(
        ["@pytest.mark.fidelity(*levels): run the test at these fidelity levels only*"]
    )


@pytest.mark.parametrize(
    ("marker", "named"),
    [
        ('"lwo"', "'lwo'"),
        ('"low", "hihg"', "'hihg'"),
        ('"low,hgih"', "'hgih'"),
        ("", "give one or more levels"),
        ("1", "give one or more levels"),
    ],
)
def test_misspelt_marker_level_is_a_collection_error(
    pytester: pytest.Pytester, marker: str, named: str
) -> None:
    pytester.makepyfile(
        test_bad=f"""
        import pytest

        @pytest.mark.fidelity({marker})
        def test_typo():
            pass

        def test_fine():
            pass
        """
    )
    result = pytester.runpytest()
    assert result.ret == pytest.ExitCode.INTERRUPTED
    result.assert_outcomes(errors=1)
    shown = marker.replace('"', "'")
    result.stdout.fnmatch_lines(
        [
            "*ERROR collecting test_bad.py*",
            f"@pytest.mark.fidelity({shown}) on test_bad.py::test_typo: *",
            "*Interrupted: 1 error during collection*",
        ]
    )
    assert named in result.stdout.str()
    assert "allowed: low, medium, high" in result.stdout.str()
    # The error is the message, not a traceback through pytest's and pluggy's internals.
    assert "pluggy/_" not in result.stdout.str()
    assert "_pytest/" not in result.stdout.str()


# -- failure reports ------------------------------------------------------------------------

FAILING = """
import pytest

@pytest.mark.fidelity("medium")
def test_fails(mcs_fidelity, mcs_seed):
    assert mcs_seed < 0, "seeded failure"

def test_passes():
    pass

@pytest.mark.parametrize("word", ["it's [odd]", "plain"])
def test_quoted(word):
    assert word == "plain"
"""


def test_failure_report_shows_seed_and_replay_command(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_failing=FAILING)
    result = pytester.runpytest("--mcs-fidelity=low,medium", "--mcs-seed=31337")
    result.assert_outcomes(passed=2, failed=2, deselected=1)
    here = pytester.path
    result.stdout.fnmatch_lines(
        [
            "*- multicosim -*",
            "verdict: AssertionError: seeded failure*",
            f"replay: {PYTEST} '{here}/test_failing.py::test_fails[[]medium[]]' --rootdir={here} "
            f"*--mcs-seed=31337 --mcs-fidelity=medium --mcs-artifacts={here}/mcs-artifacts",
            "seed 31337, fidelity medium, placement process",
            "*- multicosim -*",
            "verdict: AssertionError: assert \"it's [[]odd[]]\" == 'plain'*",
            f"replay: {PYTEST} *{here}/test_failing.py::test_quoted* --mcs-seed=31337 "
            "--mcs-fidelity=low,medium*",
            "seed 31337, fidelity low,medium, placement in-process",
        ]
    )
    assert result.stdout.str().count("- multicosim -") == 2  # passing tests get no section

    # Each replay command runs exactly its failing test again, with the same outcome, from
    # any directory and without the virtual environment on PATH: it names the interpreter.
    replays = [
        line.removeprefix("replay: ") for line in result.stdout.lines if line.startswith("replay: ")
    ]
    assert len(replays) == 2
    elsewhere = pytester.mkdir("elsewhere")
    bare = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH")}
    bare["PATH"] = os.defpath
    ids = ["test_failing.py::test_fails[medium]", "test_failing.py::test_quoted[it's [odd]]"]
    for replay, message, test_id in zip(
        replays, ["seeded failure", "it's [odd]"], ids, strict=True
    ):
        again = subprocess.run(
            [*shlex.split(replay), "-p", "no:cacheprovider"],
            cwd=elsewhere,
            env=bare,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert again.returncode == 1, again.stdout + again.stderr
        assert "1 failed" in again.stdout
        assert "seed 31337, fidelity " in again.stdout
        assert message in again.stdout
        # The same test under the same root (its id shown relative to where it was run),
        # replayable again by the very same line; nothing written where it was run from.
        assert f"{test_id} - " in again.stdout
        assert f"replay: {replay}" in again.stdout.splitlines()
    assert not (elsewhere / "mcs-artifacts").exists()


def test_failure_in_a_fixture_also_shows_the_seed(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_setup="""
        import pytest

        @pytest.fixture
        def broken(mcs_seed):
            raise RuntimeError("setup went wrong")

        def test_uses_it(broken):
            pass
        """
    )
    result = pytester.runpytest("--mcs-seed=4")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(
        [
            "verdict: RuntimeError: setup went wrong",
            f"replay: {PYTEST} {pytester.path}/test_setup.py::test_uses_it *--mcs-seed=4 *",
            "seed 4, fidelity low, placement in-process",
        ]
    )


COMPONENT_FAILS = """
import mcs_programs

def test_component_output(mcs_simulator):
    node_id = mcs_simulator.add(mcs_programs.echo_component("chatty"))
    sim = mcs_simulator.start()
    reply = sim.get(node_id).send(mcs_programs.Req(n=1, say="hello from the firmware"))
    assert reply.n == 2
"""


@pytest.mark.usefixtures("programs")
def test_failure_report_shows_component_log_and_saves_it(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_component=COMPONENT_FAILS)
    result = pytester.runpytest("--mcs-artifacts=arts")
    result.assert_outcomes(failed=1)
    test_dir = pytester.path / "arts" / "test_component.py_test_component_output_low"
    saved = test_dir / "seed-0-in-process" / "chatty.log"
    result.stdout.fnmatch_lines(
        [
            "seed 0, fidelity low, placement in-process",
            f"--- chatty: last output (full log: {saved}) ---",
            "hello from the firmware",
        ]
    )
    assert "hello from the firmware" in saved.read_text()


@pytest.mark.usefixtures("programs")
def test_keep_traces_none_saves_nothing(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_component=COMPONENT_FAILS)
    result = pytester.runpytest("--mcs-artifacts=arts", "--mcs-keep-traces=none")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["seed 0, fidelity low, placement in-process"])
    assert "last output" not in result.stdout.str()
    assert not (pytester.path / "arts").exists()


@pytest.mark.usefixtures("programs")
def test_artifacts_are_kept_per_seed_and_never_stale(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_component=COMPONENT_FAILS)
    pytester.runpytest("--mcs-artifacts=arts", "--mcs-seed=1").assert_outcomes(failed=1)
    test_dir = pytester.path / "arts" / "test_component.py_test_component_output_low"
    first = test_dir / "seed-1-in-process"
    assert {"chatty.log", "trace.mcap", "trace.layout.json"} <= {p.name for p in first.iterdir()}
    stale = first / "left-by-an-earlier-run.mcap"
    stale.write_text("old")
    # A replay with another seed writes beside the original failure's files.
    pytester.runpytest("--mcs-artifacts=arts", "--mcs-seed=2").assert_outcomes(failed=1)
    assert (test_dir / "seed-2-in-process" / "trace.mcap").is_file()
    assert stale.exists()
    # The same seed again replaces what the earlier run left: nothing stale stays beside it.
    pytester.runpytest("--mcs-artifacts=arts", "--mcs-seed=1").assert_outcomes(failed=1)
    assert not stale.exists()
    assert (first / "trace.mcap").is_file()


@pytest.mark.parametrize(("keep", "kept"), [("all", True), ("failed", False)])
@pytest.mark.usefixtures("programs")
def test_keep_traces_of_passing_tests(pytester: pytest.Pytester, keep: str, kept: bool) -> None:
    pytester.makepyfile(
        test_passing="""
        import mcs_programs

        def test_passes(mcs_simulator):
            node_id = mcs_simulator.add(mcs_programs.echo_component("quiet"))
            sim = mcs_simulator.start()
            assert sim.get(node_id).send(mcs_programs.Req(n=1, say="all went well")).n == 1
        """
    )
    result = pytester.runpytest("--mcs-artifacts=arts", f"--mcs-keep-traces={keep}")
    result.assert_outcomes(passed=1)
    assert "- multicosim -" not in result.stdout.str()  # a passing test gets no section
    log = (
        pytester.path
        / "arts"
        / "test_passing.py_test_passes_low"
        / "seed-0-in-process"
        / "quiet.log"
    )
    assert log.exists() is kept
    if kept:
        assert "all went well" in log.read_text()


# -- teardown stops simulations whatever happens --------------------------------------------


def read_pids(path: Path) -> list[int]:
    """Pids recorded one per line (empty when the file does not exist)."""
    return [int(line) for line in path.read_text().split()] if path.exists() else []


@pytest.mark.usefixtures("programs")
def test_teardown_stops_simulation_of_failing_test(
    pytester: pytest.Pytester, reaper: list[int]
) -> None:
    pytester.makepyfile(
        test_teardown="""
        from pathlib import Path
        import mcs_programs

        def test_fails_while_running(mcs_simulator):
            node_id = mcs_simulator.add(mcs_programs.echo_component())
            sim = mcs_simulator.start()
            pid = sim.get(node_id).send(mcs_programs.Req(n=1)).pid
            Path("pids").write_text(f"{pid}\\n")
            assert False, "the test failed with the simulation running"

        def test_raises_while_running(mcs_simulator):
            node_id = mcs_simulator.add(mcs_programs.echo_component())
            sim = mcs_simulator.start()
            with open("pids", "a") as f:
                f.write(f"{sim.get(node_id).send(mcs_programs.Req(n=1)).pid}\\n")
            raise RuntimeError("unexpected")

        def test_later():
            # Runs after the tests above: their components are gone already, stopped by
            # the tests' teardown rather than at the end of the session.
            for pid in map(int, Path("pids").read_text().split()):
                assert mcs_programs.process_gone(pid), pid
        """
    )
    result = pytester.runpytest()
    result.assert_outcomes(failed=2, passed=1)
    pids = read_pids(pytester.path / "pids")
    reaper.extend(pids)
    assert len(pids) == 2
    assert all(process_gone(pid) for pid in pids)


@pytest.mark.usefixtures("programs")
def test_teardown_when_start_raises(pytester: pytest.Pytester, reaper: list[int]) -> None:
    pytester.makepyfile(
        test_start="""
        from pathlib import Path
        import mcs_programs

        def test_start_fails(mcs_simulator):
            pid_file = Path("pids").resolve()
            mcs_simulator.add(mcs_programs.echo_component("first", pid_file=pid_file))
            mcs_simulator.add(mcs_programs.echo_component("second", pid_file=pid_file))
            mcs_simulator.add(mcs_programs.failing_component("broken"))
            mcs_simulator.start()
        """
    )
    result = pytester.runpytest()
    result.assert_outcomes(failed=1)
    # The error names the component, its exit code and its output.
    result.stdout.fnmatch_lines(["*NodeStartError*broken*", "*broken: no config*"])
    assert "3" in result.stdout.str()
    pids = read_pids(pytester.path / "pids")
    reaper.extend(pids)
    assert len(pids) == 2
    assert all(process_gone(pid) for pid in pids)


@pytest.mark.usefixtures("programs")
def test_teardown_of_tracked_and_fixture_simulations(
    pytester: pytest.Pytester, reaper: list[int]
) -> None:
    pytester.makepyfile(
        test_tracked="""
        from pathlib import Path

        import pytest
        import multicosim as mcs
        import mcs_programs

        @pytest.fixture
        def running(mcs_simulator):
            node_id = mcs_simulator.add(mcs_programs.echo_component("in_fixture"))
            sim = mcs_simulator.start()
            return sim.get(node_id)

        def test_both(running, mcs_simulations, mcs_seed):
            simulator = mcs.ProcessSimulator(seed=mcs_seed)
            node_id = simulator.add(mcs_programs.echo_component("tracked"))
            sim = mcs_simulations.start(simulator)
            pids = [running.send(mcs_programs.Req(n=1)).pid]
            pids.append(sim.get(node_id).send(mcs_programs.Req(n=2)).pid)
            with open("pids", "w") as f:
                f.write("\\n".join(map(str, pids)))
            pytest.fail("both simulations must stop")

        def test_later():
            # Both simulations stopped at the end of test_both, not at the end of the session.
            for pid in map(int, Path("pids").read_text().split()):
                assert mcs_programs.process_gone(pid), pid
        """
    )
    result = pytester.runpytest()
    result.assert_outcomes(failed=1, passed=1)
    pids = read_pids(pytester.path / "pids")
    reaper.extend(pids)
    assert len(pids) == 2
    assert all(process_gone(pid) for pid in pids)


@pytest.mark.usefixtures("programs")
def test_teardown_on_keyboard_interrupt(
    pytester: pytest.Pytester, reaper: list[int], isolated_runs: Path
) -> None:
    pytester.makepyfile(
        test_interrupt="""
        from pathlib import Path
        import mcs_programs

        def test_interrupted(mcs_simulator):
            node_id = mcs_simulator.add(mcs_programs.stepper_component())
            sim = mcs_simulator.start()
            reply = sim.get(node_id).send(mcs_programs.Req(n=5))
            Path("pids").write_text(str(reply.pid))
            raise KeyboardInterrupt

        def test_never_runs():
            Path("ran").write_text("")
        """
    )
    result = pytester.runpytest_subprocess(timeout=60)
    pids = read_pids(pytester.path / "pids")
    reaper.extend(pids)
    assert result.ret == pytest.ExitCode.INTERRUPTED
    result.stdout.fnmatch_lines(["*KeyboardInterrupt*"])
    assert not (pytester.path / "ran").exists()
    assert len(pids) == 1
    assert process_gone(pids[0])
    assert list(isolated_runs.iterdir()) == []  # the run directory was removed too


@pytest.mark.usefixtures("programs")
def test_ctrl_c_during_send(
    pytester: pytest.Pytester, reaper: list[int], isolated_runs: Path
) -> None:
    # A real SIGINT, as a terminal sends it, while the host waits for a firmware's reply.
    pytester.makepyfile(
        test_ctrl_c="""
        from pathlib import Path
        import mcs_programs

        def test_waits(mcs_simulator):
            node_id = mcs_simulator.add(mcs_programs.echo_component())
            node = mcs_simulator.start().get(node_id)
            Path("pids.tmp").write_text(str(node.send(mcs_programs.Req(n=1)).pid))
            Path("pids.tmp").rename("pids")
            node.send(mcs_programs.Req(n=2, stall=3600.0))
        """
    )
    child = subprocess.Popen(
        [sys.executable, "-m", "pytest", "-p", "no:xdist", "test_ctrl_c.py"],
        cwd=pytester.path,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        pid_file = pytester.path / "pids"
        deadline = time.monotonic() + 30
        while not pid_file.exists() and child.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        pids = read_pids(pid_file)
        reaper.extend(pids)
        assert len(pids) == 1, "the test did not reach its long send"
        time.sleep(0.3)  # let it enter the long send
        child.send_signal(signal.SIGINT)
        # The reply is an hour away: a run that ends at all was interrupted in the send.
        output, _ = child.communicate(timeout=300)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == pytest.ExitCode.INTERRUPTED, output.decode()
    assert b"KeyboardInterrupt" in output
    assert process_gone(pids[0])
    assert list(isolated_runs.iterdir()) == []


# -- parallel runs and the sweep ------------------------------------------------------------

PARALLEL = """
import json
import os
import time
from pathlib import Path

import pytest
import mcs_programs

RECORDS = Path(__file__).with_name("records")

@pytest.mark.parametrize("n", range(4))
def test_parallel(mcs_simulator, n):
    node_id = mcs_simulator.add(mcs_programs.echo_component())
    sim = mcs_simulator.start()
    node = sim.get(node_id)
    pid = node.send(mcs_programs.Req(n=n)).pid
    worker = os.environ["PYTEST_XDIST_WORKER"]
    record = {"worker": worker, "endpoint": node.endpoint, "pid": pid, "n": n}
    with open(RECORDS, "a") as f:
        f.write(json.dumps(record) + "\\n")
    # Wait until both workers have a simulation running, so the runs really overlap (the
    # subprocess's timeout ends a run whose other worker never starts one).
    while len({json.loads(r)["worker"] for r in RECORDS.read_text().splitlines()}) < 2:
        time.sleep(0.02)
    assert node.send(mcs_programs.Req(n=n + 100)).n == n + 100
"""


@pytest.mark.usefixtures("programs")
def test_xdist_parallel_simulations(
    pytester: pytest.Pytester, reaper: list[int], isolated_runs: Path
) -> None:
    pytester.makepyfile(test_parallel=PARALLEL)
    result = pytester.runpytest_subprocess("-n", "2", timeout=600)
    records = [json.loads(line) for line in (pytester.path / "records").read_text().splitlines()]
    reaper.extend(r["pid"] for r in records)
    result.assert_outcomes(passed=4)
    assert sorted(r["n"] for r in records) == [0, 1, 2, 3]
    first, second = records[:2]  # these two ran at the same time, on different workers
    assert first["worker"] != second["worker"]
    assert first["endpoint"] != second["endpoint"]
    assert first["pid"] != second["pid"]
    assert all(process_gone(r["pid"]) for r in records)
    assert list(isolated_runs.iterdir()) == []


KILLED_HOST = """
import shlex
import sys
import time
import mcs_programs
import multicosim as mcs

# The shell's background child stays in the component's process group but is not the
# simulator's child: only a sweep removes it once the host is gone.
grandchild = f"{shlex.quote(sys.executable)} -c 'import time; time.sleep(600)'"
simulator = mcs.ProcessSimulator()
shell = simulator.add(
    mcs.ProcessComponent(
        ["sh", "-c", f"{grandchild} & echo $! > {sys.argv[1]}.child; wait"],
        name="shell",
        ready="started",
    )
)
echo = simulator.add(mcs_programs.echo_component())
sim = simulator.start()
pids = [sim.get(shell).pid, sim.get(echo).send(mcs_programs.Req(n=1)).pid]
with open(sys.argv[1] + ".tmp", "w") as f:
    f.write("\\n".join(map(str, pids)))
import os
os.rename(sys.argv[1] + ".tmp", sys.argv[1])
time.sleep(600)
"""


@pytest.mark.usefixtures("programs")
def test_killed_host_takes_its_components_along_and_a_new_session_sweeps_the_rest(
    pytester: pytest.Pytester, reaper: list[int], isolated_runs: Path
) -> None:
    script = pytester.makepyfile(killed_host=KILLED_HOST)
    pid_file = pytester.path / "pids"
    child_file = pytester.path / "pids.child"
    host = subprocess.Popen([sys.executable, str(script), str(pid_file)], cwd=pytester.path)
    try:
        deadline = time.monotonic() + 30
        while not (pid_file.exists() and child_file.exists()) and time.monotonic() < deadline:
            assert host.poll() is None, "the host script failed"
            time.sleep(0.05)
        shell, echo = read_pids(pid_file)
        (grandchild,) = read_pids(child_file)
        reaper.extend([shell, echo, grandchild])
    finally:
        host.kill()  # SIGKILL: no teardown, no atexit, nothing runs in the host
        host.wait()
    # The components the host started die with it (parent-death signal)...
    assert process_gone(shell)
    assert process_gone(echo)
    # ... what they started in turn outlives it, until a new session sweeps the run.
    assert not process_gone(grandchild, timeout=0.5), "the grandchild must outlive its host"
    assert len(list(isolated_runs.iterdir())) == 1

    # A session sweeps once it runs a test of ours (one that uses a multicosim fixture).
    pytester.makepyfile(test_after="def test_after(mcs_seed): pass")
    pytester.runpytest_subprocess(timeout=60).assert_outcomes(passed=1)
    assert process_gone(grandchild)
    assert list(isolated_runs.iterdir()) == []


REAL_PX4_FAILS = """
def test_hover(px4_simulation, px4_autopilot):
    px4_simulation.advance(1.0)
    assert px4_autopilot == "builtin", "fails on real PX4"
"""


def test_a_real_px4_failures_replay_line_replays_from_anywhere(
    session_px4: RealPX4, pytester: pytest.Pytester, inner_env: dict[str, str]
) -> None:
    # Real PX4 named only in the environment: the replay line, run verbatim from another
    # directory in a shell without it, flies real PX4 again, fails the same way and replaces
    # the first run's artifacts.
    binary = session_px4.binary
    if binary is None:
        pytest.skip("no real PX4 binary configured (--mcs-px4-binary or MCS_PX4_BINARY)")
    pytester.makepyfile(test_real=REAL_PX4_FAILS)
    env = inner_env
    first = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--mcs-fidelity=medium"],
        cwd=pytester.path,
        env={**env, "MCS_PX4_BINARY": binary},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert "1 failed, 1 passed" in first.stdout, first.stdout + first.stderr
    replays = [line[len("replay: ") :] for line in first.stdout.splitlines() if "replay: " in line]
    assert len(replays) == 1
    assert "--mcs-px4-binary=" in replays[0]
    artifacts = pytester.path / "mcs-artifacts"
    before = {p: p.stat().st_mtime_ns for p in artifacts.rglob("*") if p.is_file()}
    assert before, "the failing run kept no artifacts"
    elsewhere = pytester.mkdir("elsewhere")
    again = subprocess.run(
        [*shlex.split(replays[0]), "-p", "no:cacheprovider"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert "1 failed" in again.stdout, again.stdout + again.stderr
    assert "fails on real PX4" in again.stdout
    assert not (elsewhere / "mcs-artifacts").exists()
    after = {p: p.stat().st_mtime_ns for p in artifacts.rglob("*") if p.is_file()}

    def kinds(files: dict[Path, int]) -> list[tuple[Path, str]]:
        # (PX4 names its ULog by the time of day: the same kind of file, another name.)
        return sorted((p.parent, p.suffix) for p in files)

    assert kinds(after) == kinds(before)
    assert min(after.values()) > max(before.values())  # all written again
