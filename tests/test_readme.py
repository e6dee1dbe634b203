"""The README's examples run as written."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs

README = Path(__file__).resolve().parents[1] / "README.md"


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)


def test_quick_start_listing_runs() -> None:
    namespace: dict[str, Any] = {}
    exec(compile(_python_blocks()[0], "README quick start", "exec"), namespace)
    # The cart moves at 5 m/s from t=0.01 s until the driver's last step at t=1.95 s.
    assert namespace["report"].positions[-1] == pytest.approx(9.75)


def test_component_listing_runs_in_process() -> None:
    from multicosim import testing

    namespace: dict[str, Any] = {"mcs": mcs, "testing": testing}
    exec(compile(_python_blocks()[1], "README components", "exec"), namespace)
    simulator = mcs.ProcessSimulator()
    simulator.add(mcs.ParticipantComponent(namespace["Cart"], name="cart"))
    node_id = simulator.add(mcs.InProcessFirmwareComponent(namespace["controller"]))
    with simulator.start() as simulation:
        x = simulation.get(node_id).send(namespace["Mission"](speed=2.0, duration=1.0))
    assert x == pytest.approx(2.0)


def test_pytest_listing_passes(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        "import multicosim as mcs\nfrom multicosim import testing\n" + _python_blocks()[2]
    )
    result = pytester.runpytest("--mcs-fidelity=low,medium,high", "-rs")
    result.assert_outcomes(passed=2, skipped=1)
    result.stdout.fnmatch_lines(["*fidelity 'high' not in the test's levels (low, medium)*"])
