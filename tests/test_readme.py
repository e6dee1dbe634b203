"""The README's examples run as written."""

from __future__ import annotations

import contextlib
import fnmatch
import io
import itertools
import os
import re
import sys
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
from pytest_multicosim.docker import require_docker
from pytest_multicosim.px4 import RealPX4

README = Path(__file__).resolve().parents[1] / "README.md"
CARTPOLE = Path(__file__).resolve().parent / "physics" / "cartpole.py"
# What the README's listings name real firmware by: placeholders a reader replaces.
PX4_PLACEHOLDER = '"/path/to/PX4-Autopilot/build/px4_sitl_default/bin/px4"'
ARDUPILOT_PLACEHOLDER = '"/path/to/ardupilot-sitl"'


def _block(containing: str) -> str:
    """The README's Python block that contains ``containing`` (exactly one must)."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
    found = [b for b in blocks if containing in b]
    assert len(found) == 1, f"{len(found)} README blocks contain {containing!r}"
    return str(found[0])


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
    # "..." in the README stands for what varies (floats drawn by a search, times).
    pattern = shown.replace("[", "[[]").replace("...", "*")
    return fnmatch.fnmatchcase(printed, pattern)


def _run(
    containing: str, namespace: dict[str, Any] | None = None, code: str | None = None
) -> dict[str, Any]:
    """Run the README block containing ``containing`` as written; check what it prints."""
    namespace = {} if namespace is None else namespace
    code = _block(containing) if code is None else code
    output = io.StringIO()
    with contextlib.redirect_stdout(output):
        exec(compile(code, f"README block with {containing!r}", "exec"), namespace)
    sys.stdout.write(output.getvalue())  # still there for capsys and for reading
    printed = output.getvalue().splitlines()
    for shown in _shown(code):
        # Each shown output is printed, in order.
        while printed and not _matches(printed[0], shown):
            printed.pop(0)
        assert printed, f"the README block with {containing!r} did not print {shown!r}"
        printed.pop(0)
    return namespace


def test_every_print_in_the_readme_shows_its_output() -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
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
    shown = re.search(r"```\n(check_component\(.*?)```", README.read_text(), flags=re.DOTALL)
    assert shown is not None
    assert printed == shown.group(1)


def test_pytest_listing_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(_block("def test_cart_reaches_the_goal"))
    result = pytester.runpytest("--mcs-fidelity=low,medium,high", "-rs")
    result.assert_outcomes(passed=2, deselected=1)
    result.stdout.fnmatch_lines(["multicosim: 1 deselected at fidelity levels they never run at"])


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


def test_px4_listing_runs() -> None:
    result = _run("simulator = px4.PX4(world")["result"]
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
    code = _block("ardupilot.Copter(").replace(ARDUPILOT_PLACEHOLDER, repr(ardupilot_dir))
    namespace: dict[str, Any] = {}
    exec(compile(code, "README block with ardupilot.Copter", "exec"), namespace)
    result = namespace["result"]
    assert result.completed, result.reason
    assert result.firmware_version == "4.5.6"
    assert [r.index for r in result.reached] == [0]
    assert result.landed  # home again: the mission ended with a return to launch


def test_rover_listings_run() -> None:
    namespace = _run("rover.Rover(fidelity=")
    assert namespace["trajectory"].completed  # the hand-built medium-fidelity run


def test_own_vehicle_listings_run(monkeypatch: pytest.MonkeyPatch) -> None:
    # The README's module is the test suite's cart-pole, which its own tests check further.
    assert _block('"""cartpole.py: ') == CARTPOLE.read_text()
    here = str(CARTPOLE.parent)
    monkeypatch.syspath_prepend(here)
    monkeypatch.setenv(
        "PYTHONPATH", os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p)
    )
    namespace = _run("replytype=cartpole.State")
    assert namespace["state"].x == pytest.approx(0.5, abs=0.01)
    namespace = _run('sensor_topics={"state"', namespace)
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
    result = _run("from multicosim.falsify import Integer, falsify")["result"]
    assert result.falsified, result.summary()
    cx = result.counterexample
    assert cx.failing_levels == ("low", "medium")  # found cheaply, confirmed by physics
    assert set(cx.example) == {"speed", "rate", "iterations"}
    assert isinstance(cx.example["iterations"], int)
    assert result.transfer_rates["medium"] == 1.0


def test_docker_listing_runs() -> None:
    require_docker()
    from multicosim.docker import RUNTIME_IMAGE, build_images

    assert RUNTIME_IMAGE in build_images()
    assert _run("simulator = ContainerSimulator()")["trajectory"].completed
