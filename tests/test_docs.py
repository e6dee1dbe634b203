"""The documentation's examples run as written: the README's and every page's under docs/.

Each Python block is run by a test here, found by a string only it contains (``LISTINGS``);
what its prints claim to print is checked. A block that cannot run as it stands (a synopsis
with ``...`` or files the reader supplies) says so on the line before it with ``SKETCH``,
and claims no output.
"""

from __future__ import annotations

import contextlib
import fnmatch
import html
import importlib
import inspect
import io
import itertools
import os
import pkgutil
import re
import sys
import textwrap
import zlib
from importlib import metadata
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
from multicosim import px4
from multicosim.core.geo import LocalProjection
from pytest_multicosim.docker import require_docker
from pytest_multicosim.px4 import RealPX4

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = (README, *sorted((ROOT / "docs").rglob("*.md")))
CARTPOLE = Path(__file__).resolve().parent / "physics" / "cartpole.py"
SKETCH = "<!-- a sketch: not run -->"
# What the listings name real firmware by: placeholders a reader replaces with a build.
PX4_PLACEHOLDER = '"/path/to/PX4-Autopilot/build/px4_sitl_default/bin/px4"'
ARDUPILOT_PLACEHOLDER = '"/path/to/ardupilot-sitl"'

# The string that finds each block a test runs (each in exactly one block).
LISTINGS = (
    "replytype=testing.DriveReport",
    "class Cart:",
    "report = check_component(",
    "def test_cart_reaches_the_goal",
    'FMUS = "../shared/reference-fmus"',
    "def test_the_ball_stays_above_the_floor",
    'simulator = px4.PX4(world, fidelity="low")',
    "firmware = px4.SITL(binary=",
    "px4.sitl_level(",
    'end="rtl"',
    'end="land"',
    'rover.Rover(fidelity="low", seed=1)',
    '"""cartpole.py: ',
    "replytype=cartpole.State,\n)\nsimulator",
    'sensor_topics={"state"',
    "mtaliro.falsify(",
    "from multicosim.search.falsify import Integer, falsify",
    "simulator = ContainerSimulator()",
    'executor="ray"',
    "real = px4.PX4(",
    "def test_the_mission_stays_below_30_m",
    "def test_altitude(px4_simulation):",
    "def test_the_corridor_keeps_clear_of_the_mast",
    'px4.Configuration.from_plan("tests/data/survey_site.plan")',
    'AEROBENCH = "../shared/aerobench"',
    "def test_the_gcas_pulls_out_of_the_dive",
    'fleet.PX4Vehicle(start=Pose(north=80.0))},\n    fidelity="low"',
    "def test_crossing_drones_lose_well_clear_but_never_touch",
    "def test_close_encounters_never_collide",
    'attacks.inject(spoofed, "bravo/gps"',
    "real_ardupilot = ardupilot.SITL(",
)

_FENCE = re.compile(r"^(?P<indent> *)```python\n(?P<code>.*?)^(?P=indent)```", re.M | re.S)


def _blocks(*, sketches: bool = False) -> list[tuple[Path, str]]:
    """Every Python block of the README and the docs pages (without the sketches)."""
    found = []
    for page in PAGES:
        text = page.read_text()
        for match in _FENCE.finditer(text):
            before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1].strip()
            if (before == SKETCH) == sketches:
                found.append((page, textwrap.dedent(match.group("code"))))
    return found


def _block(containing: str) -> str:
    """The one block, on any page, that contains ``containing``."""
    assert containing in LISTINGS, f"{containing!r} is not in LISTINGS"
    # The README shows one page's example again: copies must be the same.
    found = {code for _, code in _blocks() if containing in code}
    assert len(found) == 1, f"{len(found)} different blocks contain {containing!r}"
    return found.pop()


def _shown(block: str) -> list[str]:
    """What the block says its prints print: a top-level print's comment, or the next line's."""
    shown = []
    for line, after in itertools.pairwise([*block.splitlines(), ""]):
        if not line.startswith("print("):
            continue
        if "  # " in line:  # print(x)  # what it prints
            shown.append(line.split("  # ", 1)[1])
        elif after.startswith("# "):
            shown.append(after.removeprefix("# "))
    return shown


def _matches(printed: str, shown: str) -> bool:
    # "..." in the docs stands for what varies (floats drawn by a search, times).
    pattern = shown.replace("[", "[[]").replace("...", "*")
    return fnmatch.fnmatchcase(printed, pattern)


def _run(
    containing: str, namespace: dict[str, Any] | None = None, code: str | None = None
) -> dict[str, Any]:
    """Run the block containing ``containing`` as written; check what it prints."""
    namespace = {} if namespace is None else namespace
    code = _block(containing) if code is None else code
    output = io.StringIO()
    with contextlib.redirect_stdout(output):
        exec(compile(code, f"block with {containing!r}", "exec"), namespace)
    sys.stdout.write(output.getvalue())  # still there for capsys and for reading
    printed = output.getvalue().splitlines()
    for shown in _shown(code):
        # Each shown output is printed, in order.
        while printed and not _matches(printed[0], shown):
            printed.pop(0)
        assert printed, f"the block with {containing!r} did not print {shown!r}"
        printed.pop(0)
    return namespace


def test_every_block_is_run_by_a_test() -> None:
    blocks = _blocks()
    assert len(blocks) >= len(LISTINGS)
    for page, code in blocks:
        claimed = [listing for listing in LISTINGS if listing in code]
        assert len(claimed) == 1, (
            f"a block in {page.relative_to(ROOT)} is found by {claimed}: every Python block "
            f"is run by a test in {Path(__file__).name} (or marked {SKETCH!r} on the line "
            f"before it)\n{code[:300]}"
        )


def test_the_readmes_links_lead_to_files() -> None:
    # The site's own links are checked by mkdocs build --strict; the README is outside it.
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README.read_text())
    local = [t for t in targets if not t.startswith(("http://", "https://"))]
    assert len(local) >= 20
    assert [t for t in local if not (ROOT / t).is_file()] == []


def test_sketches_claim_no_output() -> None:
    for page, code in _blocks(sketches=True):
        assert not _shown(code), f"a sketch in {page.relative_to(ROOT)} claims an output"


def test_every_print_in_the_docs_shows_its_output() -> None:
    blocks = [code for _, code in _blocks()]
    prints = [b for b in blocks if "\nprint(" in "\n" + b and "summary()" not in b]
    assert prints
    assert all(_shown(block) or "check_component" in block for block in prints)


def test_quick_start_listing_runs() -> None:
    namespace = _run("replytype=testing.DriveReport")
    # The cart moves at 5 m/s from t=0.01 s until the driver's last step at t=1.95 s.
    assert namespace["report"].positions[-1] == pytest.approx(9.75)


def test_component_listing_runs_in_process() -> None:

    namespace = _run("class Cart:")
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.InProcessComponent(namespace["Cart"], name="cart"))
    node_id = simulator.add(mcs.InProcessFirmwareComponent(namespace["controller"]))
    with simulator.start() as simulation:
        x = simulation.get(node_id).send(namespace["Mission"](speed=2.0, duration=1.0))
    assert x == pytest.approx(2.0)


def test_check_component_listing_prints_its_report(capsys: pytest.CaptureFixture[str]) -> None:
    _run("report = check_component(")
    printed = capsys.readouterr().out
    pages = "".join(page.read_text() for page in PAGES)
    shown = re.findall(r"```\n(check_component\(.*?)```", pages, flags=re.DOTALL)
    assert len(shown) == 1
    assert printed == shown[0]


def test_pytest_listing_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(_block("def test_cart_reaches_the_goal"))
    result = pytester.runpytest("--mcs-fidelity=low,medium,high", "-rs")
    result.assert_outcomes(passed=2, deselected=1)
    result.stdout.fnmatch_lines(["multicosim: 1 deselected at fidelity levels they never run at"])


def test_px4_pytest_listing_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(_block("def test_the_mission_stays_below_30_m"))
    pytester.runpytest("--mcs-fidelity=low,medium").assert_outcomes(passed=2)


def test_plan_listing_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)  # its files are the project's
    result = _run('px4.Configuration.from_plan("tests/data/survey_site.plan")')["result"]
    assert result.completed, result.reason
    assert "has no effect" in " ".join(result.messages)  # its camera command, noted


def test_uav_listings_pass(pytester: pytest.Pytester) -> None:
    # The Python test and the file of the same test, both run from the project's root.
    pytester.makepyfile(test_corridor=_block("def test_the_corridor_keeps_clear_of_the_mast"))
    page = (ROOT / "docs" / "tutorials" / "uav-test.md").read_text()
    # The case files written out (the competition's example is included from its file).
    blocks = re.findall(r"```yaml\n(.*?)```", page, flags=re.DOTALL)
    cases = [block for block in blocks if not block.startswith("--8<--")]
    assert len(cases) == 2, "one vehicle's case and a case of several"
    for case in cases:
        name = case.splitlines()[0].removeprefix("# ")
        assert (ROOT / name).read_text() == case, f"the page shows {name} as it is"
    (pytester.path / "scenarios" / "uav").mkdir(parents=True)
    for name in (
        "corridor.plan",
        "test_mast_beside_leg.mcs.yaml",
        "crossing-north.plan",
        "crossing-east.plan",
        "test_crossing_pair.mcs.yaml",
    ):
        source = ROOT / "scenarios" / "uav" / name
        (pytester.path / "scenarios" / "uav" / name).write_text(source.read_text())
    result = pytester.runpytest("--mcs-fidelity=low", "-p", "no:randomly")
    result.assert_outcomes(passed=3)


def test_failing_listing_reports_as_shown(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_mission=_block("def test_altitude(px4_simulation):"))
    # In a process of its own, as a user runs it: pytester's in-process runs restore
    # sys.modules after each run, and after another in-process run of PX4 tests the report
    # came without its MAVLink log (two pytest sessions in one process run the same way).
    result = pytester.runpytest_subprocess("--mcs-fidelity=low", "--mcs-artifacts=artifacts")
    result.assert_outcomes(failed=1)
    page = (ROOT / "docs" / "how-to" / "failing-runs.md").read_text()
    shown = re.findall(r"```\n(verdict: .*?)```", page, flags=re.DOTALL)
    assert len(shown) == 1
    # "..." stands for what varies (robustness figures, where the test and artifacts lie).
    lines = [line.replace("[", "[[]").replace("...", "*") for line in shown[0].splitlines()]
    result.stdout.fnmatch_lines(lines)


def test_fmu_listing_runs(reference_fmus: Path) -> None:
    listing = 'FMUS = "../shared/reference-fmus"'
    code = _block(listing).replace('"../shared/reference-fmus"', repr(str(reference_fmus)))
    namespace = _run(listing, code=code)
    # At rest y = u = 0.5 (1 - y): a third, on every axis.
    assert namespace["result"]["y"][-1] == pytest.approx([1 / 3] * 3, abs=1e-6)


def test_fmu_pytest_listing_passes(
    pytester: pytest.Pytester, reference_fmus: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MCS_REFERENCE_FMUS", str(reference_fmus))
    pytester.makepyfile(_block("def test_the_ball_stays_above_the_floor"))
    result = pytester.runpytest("--mcs-fidelity=low,medium")
    result.assert_outcomes(passed=2)


def test_aerobench_listing_runs(aerobench: Any) -> None:
    listing = 'AEROBENCH = "../shared/aerobench"'
    code = _block(listing).replace('"../shared/aerobench"', repr(str(aerobench.root)))
    namespace = _run(listing, code=code)
    counterexample = namespace["result"].counterexample
    assert counterexample.results["medium"].evaluation.robustness < 0


def test_f16_pytest_listing_passes(
    pytester: pytest.Pytester, aerobench: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MCS_AEROBENCH_DIR", str(aerobench.root))
    pytester.makepyfile(_block("def test_the_gcas_pulls_out_of_the_dive"))
    # In a process of its own: scipy cannot be imported again by a second in-process session.
    result = pytester.runpytest_subprocess("--mcs-fidelity=low,medium")
    result.assert_outcomes(passed=2)


def test_px4_listing_runs() -> None:
    result = _run('simulator = px4.PX4(world, fidelity="low")')["result"]
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0]  # the one waypoint


def test_real_px4_listing_runs(px4_sitl: RealPX4) -> None:
    if px4_sitl.binary is None:
        pytest.skip("the listing runs a PX4 binary")
    code = _block("firmware = px4.SITL(binary=")
    code = code.replace(PX4_PLACEHOLDER, repr(px4_sitl.binary))
    result = _run("firmware = px4.SITL(binary=", code=code)["result"]
    assert result.completed, result.reason
    assert result.firmware_version == "1.15.4"
    assert [r.index for r in result.reached] == [0]


def test_real_px4_search_listing_runs(px4_sitl: RealPX4) -> None:
    if px4_sitl.binary is None:
        pytest.skip("the listing runs a PX4 binary")
    code = _block("px4.sitl_level(").replace(PX4_PLACEHOLDER, repr(px4_sitl.binary))
    result = _run("px4.sitl_level(", code=code)["result"]
    assert result.falsified, result.summary()
    assert result.counterexample.failing_levels == ("low", "medium", "px4-sitl")
    # Each level confirmed at least the violation the search ended on.
    assert set(result.transfer_rates) == {"medium", "px4-sitl"}
    assert all(0 < rate <= 1 for rate in result.transfer_rates.values())


def test_ardupilot_listing_runs(ardupilot_dir: str) -> None:
    code = _block('end="rtl"').replace(ARDUPILOT_PLACEHOLDER, repr(ardupilot_dir))
    result = _run('end="rtl"', code=code)["result"]
    assert result.completed, result.reason
    assert result.firmware_version == "4.5.6"
    assert [r.index for r in result.reached] == [0]
    assert result.landed  # home again: the mission ended with a return to launch


def test_rover_listings_run() -> None:
    namespace = _run('rover.Rover(fidelity="low", seed=1)')
    assert namespace["trajectory"].completed  # the hand-built medium-fidelity run


def test_own_vehicle_listings_run(monkeypatch: pytest.MonkeyPatch) -> None:
    # The docs' module is the test suite's cart-pole, which its own tests check further.
    assert _block('"""cartpole.py: ') == CARTPOLE.read_text()
    here = str(CARTPOLE.parent)
    monkeypatch.syspath_prepend(here)
    monkeypatch.setenv(
        "PYTHONPATH", os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p)
    )
    namespace = _run("replytype=cartpole.State,\n)\nsimulator")
    assert namespace["state"].x == pytest.approx(0.5, abs=0.01)
    namespace = _run('sensor_topics={"state"')
    # The pole stands upright; the controller rests where 10 (x - 0.5) + 65 * 0.02 = 0.
    assert namespace["state"].x == pytest.approx(0.5 - 65 / 10 * 0.02, abs=0.01)


def test_psy_taliro_listing_runs() -> None:
    result = _run("mtaliro.falsify(")["result"]
    # The autopilot never takes the vehicle below its home: nothing falsifies "alt > 0"
    # (robustness 0 on the ground at the start, where "always" takes its minimum).
    assert not result.falsified
    assert result.robustness == 0.0
    assert set(result.sample) == {"iters", "step_size", "lat", "lon", "alt"}


def test_search_listing_runs() -> None:
    result = _run("from multicosim.search.falsify import Integer, falsify")["result"]
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx.failing_levels == ("low", "medium")  # found cheaply, confirmed by physics
    assert set(cx.example) == {"speed", "rate", "iterations"}
    assert isinstance(cx.example["iterations"], int)
    assert result.transfer_rates["medium"] == 1.0


def test_fleet_listing_runs() -> None:
    result = _run('fleet.PX4Vehicle(start=Pose(north=80.0))},\n    fidelity="low"')["result"]
    approach = result.encounter.closest["alpha-bravo"]
    # They pass at their altitudes' difference, less their bodies' radii.
    assert approach.separation == pytest.approx(4.5, abs=0.3)


def test_fleet_spoof_listing_runs() -> None:
    result = _run('attacks.inject(spoofed, "bravo/gps"')["flown"]
    end = result.results["bravo"].trajectory[-1]
    east = LocalProjection(px4.Home().lat, px4.Home().lon).project(end.true_lat, end.true_lon)[1]
    assert east == pytest.approx(24.0, abs=1.0), "bravo flew where its GPS said, not 6 m west"


def test_fleet_pytest_listing_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(_block("def test_crossing_drones_lose_well_clear_but_never_touch"))
    # In a process of its own: an in-process run would drop the fleet's modules (and the
    # PX4 classes they import) from sys.modules after it, under the other tests' feet.
    result = pytester.runpytest_subprocess("--mcs-fidelity=low,medium")
    result.assert_outcomes(passed=2)


def test_fleet_encounters_listing_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(_block("def test_close_encounters_never_collide"))
    result = pytester.runpytest_subprocess()
    result.assert_outcomes(passed=1)


def test_fleet_of_every_autopilot_listing_runs(px4_sitl: RealPX4, ardupilot_dir: str) -> None:
    if px4_sitl.binary is None:
        pytest.skip("the listing runs a PX4 binary")
    code = _block("real_ardupilot = ardupilot.SITL(")
    code = code.replace(PX4_PLACEHOLDER, repr(px4_sitl.binary))
    code = code.replace(ARDUPILOT_PLACEHOLDER, repr(ardupilot_dir))
    result = _run("real_ardupilot = ardupilot.SITL(", code=code)["result"]
    assert result.results["px4"].firmware_version == "1.15.4"
    assert result.results["copter"].firmware_version == "4.5.6"
    assert not result.encounter.collisions


def test_docker_listing_runs() -> None:
    require_docker()
    from multicosim.docker import RUNTIME_IMAGE, build_images

    assert RUNTIME_IMAGE in build_images()
    assert _run("simulator = ContainerSimulator()")["trajectory"].completed


def test_ardupilot_guide_listing_runs(ardupilot_dir: str) -> None:
    code = _block('end="land"').replace(ARDUPILOT_PLACEHOLDER, repr(ardupilot_dir))
    result = _run('end="land"', code=code)["result"]
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0]
    assert result.landed


def test_px4_guide_listing_runs(tmp_path: Path) -> None:
    # It flies at low and configures real PX4 without starting it: a build's layout will do.
    (tmp_path / "bin").mkdir()
    (tmp_path / "etc" / "init.d-posix" / "airframes").mkdir(parents=True)
    (tmp_path / "etc" / "init.d-posix" / "rcS").write_text("")
    (tmp_path / "etc" / "init.d-posix" / "airframes" / "10016_none_iris").write_text("")
    binary = tmp_path / "bin" / "px4"
    binary.write_text("")
    binary.chmod(0o755)
    code = _block("real = px4.PX4(").replace(PX4_PLACEHOLDER, repr(str(binary)))
    namespace = _run("real = px4.PX4(", code=code)
    assert [r.index for r in namespace["result"].reached] == [0]
    assert namespace["real"].fidelity == "medium"


def test_campaign_listing_runs_on_ray(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("ray", reason="ray is not installed (pip install 'multicosim[ray]')")
    monkeypatch.chdir(tmp_path)  # the listing writes to ./out
    result = _run('executor="ray"')["result"]
    assert result.executor == "ray"
    assert len(result.results) == 100
    # Speeds drawn over 1 to 8 m/s: the rover holds some above 4.5 m/s, some not.
    assert {r.status for r in result.results} == {"ok", "violated"}
    assert (tmp_path / "out" / "results.csv").exists()


# The modules whose ``__all__`` the API reference renders, one page each (docs/reference/api/).
API = (
    "multicosim",
    "multicosim.testing",
    "multicosim.local",
    "multicosim.runtime",
    "multicosim.placement",
    "multicosim.docker",
    "multicosim.ray",
    "multicosim.physics",
    "multicosim.px4",
    "multicosim.px4.competition",
    "multicosim.ardupilot",
    "multicosim.rover",
    "multicosim.f16",
    "multicosim.fleet",
    "multicosim.attacks",
    "multicosim.search.requirements",
    "multicosim.search.falsify",
    "multicosim.search.campaign",
    "multicosim.search.taliro",
    "multicosim.search.strategies",
    "multicosim.core.geo",
    "multicosim.fmi",
    "multicosim.trace",
)
# The other public subpackages, and where their public names are documented.
DOCUMENTED_ELSEWHERE = {
    "multicosim.core": "its public names are multicosim's, and multicosim.core.geo's",
    "multicosim.search": "its modules' pages: requirements, falsify, campaign, ...",
    "multicosim.mavlink": "what PX4 and ArduPilot share; multicosim.px4 exports its types",
    "multicosim.quadrotor": "the body PX4 and ArduCopter fly; the PX4 guide describes it",
    "multicosim.cli": "the multicosim command: multicosim --help",
}


def _inventory(site: Path) -> set[str]:
    """The names the built site's objects.inv (Sphinx's inventory format) lists."""
    with (site / "objects.inv").open("rb") as file:
        for _ in range(4):  # the header
            file.readline()
        body = zlib.decompress(file.read()).decode()
    return {line.split(" ", 1)[0] for line in body.splitlines()}


def _home(value: Any) -> str:
    """Where ``value`` is defined: a function named like its module is documented there."""
    return f"{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', '')}"


def test_every_public_name_is_in_the_api_reference(site: Path) -> None:
    documented = _inventory(site)
    missing = [
        f"{module}.{name}"
        for module in API
        for name in importlib.import_module(module).__all__
        if not {f"{module}.{name}", _home(getattr(importlib.import_module(module), name))}
        & documented
    ]
    assert not missing, f"not in the API reference (docs/reference/api/): {missing}"
    for page in API:
        assert (ROOT / "docs" / "reference" / "api" / f"{page.split('.')[-1]}.md").exists()


def test_every_public_class_and_function_has_a_docstring() -> None:
    undocumented = []
    for module in API:
        for name in importlib.import_module(module).__all__:
            value = getattr(importlib.import_module(module), name)
            if not (inspect.isclass(value) or inspect.isfunction(value)):
                continue
            # A class's own docstring: not inherited, not the one dataclasses make up.
            doc = (vars(value).get("__doc__") if inspect.isclass(value) else value.__doc__) or ""
            if not doc.strip() or doc.startswith(f"{value.__name__}("):
                undocumented.append(f"{module}.{name}")
    assert undocumented == []


def test_every_public_subpackage_is_documented() -> None:
    public = {
        f"multicosim.{info.name}"
        for info in pkgutil.iter_modules(mcs.__path__)
        if not info.name.startswith("_")
    }
    # A page per public module, or for its modules (multicosim.search's, multicosim.core.geo).
    paged = {".".join(name.split(".")[:2]) for name in API if name != "multicosim"}
    assert public - {"multicosim.__main__"} == paged | set(DOCUMENTED_ELSEWHERE)


def test_every_option_ini_key_fixture_and_marker_is_in_the_reference() -> None:
    import pytest_multicosim.options as options
    from pytest_multicosim.fidelity import MARKER

    page = (ROOT / "docs" / "reference" / "pytest.md").read_text()
    source = inspect.getsource(options)
    names = re.findall(r'"(--mcs-[a-z0-9-]+)"', source) + re.findall(r'addini\("(\w+)"', source)
    assert len(names) >= 18
    missing = [name for name in names if f"`{name}" not in page]
    assert not missing, f"not in docs/reference/pytest.md: {missing}"
    assert f"`@pytest.mark.{MARKER.split(':')[0]}`" in page
    # Every fixture library's module is rendered there (its fixtures with their docstrings).
    libraries = [
        "pytest_multicosim.fixtures",
        *(ep.value for ep in metadata.entry_points(group="multicosim.fixtures")),
    ]
    rendered = set(re.findall(r"^::: (pytest_multicosim\.\w+)$", page, flags=re.M))
    assert set(libraries) <= rendered
    fixtures = [
        name
        for module in libraries
        for name, value in vars(importlib.import_module(module)).items()
        if type(value).__name__ == "FixtureFunctionDefinition"
    ]
    assert {"mcs_simulator", "px4_simulation", "fmu"} <= set(fixtures)
    for module in libraries:  # what the page renders: the module's public names
        assert set(fixtures) & set(vars(importlib.import_module(module))) <= {
            name for m in libraries for name in importlib.import_module(m).__all__
        }


RAW_ROLE = re.compile(r":(class|func|meth|attr|data|mod|exc|obj|param|returns?|raises):")
LITERAL_BLOCK = re.compile(r"\S::(?:\s|$)")


def _prose(page: Path) -> str:
    """A page's text as shown, without its code blocks and scripts."""
    text = re.sub(r"<(pre|script|style)\b.*?</\1>", "", page.read_text(), flags=re.S)
    return html.unescape(re.sub(r"<[^>]+>", "", text))


def test_the_site_shows_no_raw_markup(site: Path) -> None:
    """Docstrings are Markdown (cross-references as links, examples as fenced code): no
    reStructuredText role or literal block reaches a reader."""
    raw = {}
    for page in sorted(site.rglob("*.html")):
        text = _prose(page)
        found = [m.group(0) for m in RAW_ROLE.finditer(text)]
        found += [text[max(m.start() - 30, 0) : m.end()] for m in LITERAL_BLOCK.finditer(text)]
        if found:
            raw[str(page.relative_to(site))] = found[:3]
    assert not raw, f"raw reStructuredText on the site: {raw}"
