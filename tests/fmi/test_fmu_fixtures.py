"""The ``fmu`` fixture in a pytest session: components at the test's fidelity, fidelity
markers, requirements over FMU outputs, and failing tests whose traces Foxglove opens with
the FMUs' channels (read back with the mcap library and checked against their schemas)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from mcap.reader import make_reader

from multicosim.placement import default_placement

SUITE = """
import os

import pytest

import multicosim as mcs
from multicosim import fmi
from multicosim.search.requirements import Requirement

LOGGING = os.environ["LOGGING_FMU"]


@pytest.mark.fidelity("low", "medium")
def test_the_ball_stays_low(fmu, reference_fmus):
    result = fmu.simulate(reference_fmus / "fmi3" / "BouncingBall.fmu", stop_time=3.0)
    Requirement("always (h <= 0.9)").check(result)


@pytest.mark.fidelity("low")
def test_the_logging_fmu(fmu):
    simulator = fmu.simulator()
    node_id = simulator.add(fmu(LOGGING, name="plant", period=0.1, debug_logging=True))
    simulation = simulator.start()
    simulation.advance(1.0)
    lines = simulation.get(node_id).log()
    assert not lines, lines[0].message


@pytest.mark.fidelity("low", "medium")
def test_where_the_fmus_run(fmu, mcs_fidelity, reference_fmus):
    component = fmu(reference_fmus / "fmi2" / "Dahlquist.fmu")
    assert component.placement.name == {"low": "in-process", "medium": "process"}[mcs_fidelity]
    result = fmu.simulate(reference_fmus / "fmi2" / "Dahlquist.fmu")
    Requirement("always (x >= 0)").check(result)
"""


@pytest.fixture(scope="module")
def failing_run(
    tmp_path_factory: pytest.TempPathFactory,
    inner_env: dict[str, str],
    reference_fmus: Path,
    faulty_fmu: Callable[[str], Path],
) -> tuple[Path, str]:
    """Run the suite once: three failures, two passes, one skip."""
    path = tmp_path_factory.mktemp("fmu_suite")
    (path / "pytest.ini").write_text(
        "[pytest]\naddopts = --strict-markers -p no:cacheprovider\nfilterwarnings = error\n"
    )
    (path / "test_fmus.py").write_text(SUITE)
    env = {
        **inner_env,
        "MCS_REFERENCE_FMUS": str(reference_fmus),
        "LOGGING_FMU": str(faulty_fmu("log")),
    }
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-rs",
            "--mcs-fidelity=low,medium",
            "--mcs-artifacts=arts",
        ],
        cwd=path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert "3 failed, 2 passed, 1 deselected" in result.stdout, result.stdout[-4000:]
    return path, result.stdout


def _read(trace: Path) -> tuple[dict[str, Any], dict[str, list[Any]]]:
    schemas: dict[str, Any] = {}
    messages: dict[str, list[Any]] = {}
    with open(trace, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            assert schema is not None
            schemas[channel.topic] = (schema.name, json.loads(schema.data))
            messages.setdefault(channel.topic, []).append(json.loads(message.data))
    return schemas, messages


def _artifacts(path: Path, test: str) -> Path:
    # Each fidelity's default placement: in-process at low, local processes above.
    placement = default_placement("low" if test.endswith("_low") else "medium")
    return path / "arts" / f"test_fmus.py_{test}" / f"seed-0-{placement}"


@pytest.mark.parametrize("level", ["low", "medium"])
def test_a_failing_fmu_test_leaves_a_trace_with_the_fmus_channel(
    failing_run: tuple[Path, str], level: str
) -> None:
    path, output = failing_run
    directory = _artifacts(path, f"test_the_ball_stays_low_{level}")
    schemas, messages = _read(directory / "trace.mcap")
    name, schema = schemas["BouncingBall"]
    assert name == "multicosim.fmi.records.BouncingBall"
    assert schema["properties"]["h"]["unit"] == "m"  # units from the model description
    assert schema["properties"]["h"]["causality"] == "output"
    validator = jsonschema.Draft202012Validator(schema)
    for record in messages["BouncingBall"]:
        validator.validate(record)
    assert len(messages["BouncingBall"]) == 751  # every communication point to 3 s
    assert messages["BouncingBall"][0]["h"] == 1.0
    # The requirement's signals and margin, and a plot of the FMU's outputs in the layout.
    assert {"mcs/trajectory", "mcs/robustness"} <= schemas.keys()
    layout = json.loads((directory / "trace.layout.json").read_text())
    assert "FMU BouncingBall" in json.dumps(layout)
    assert "first violated at t=" in output


def test_the_fmus_log_is_a_foxglove_log_channel(failing_run: tuple[Path, str]) -> None:
    path, output = failing_run
    schemas, messages = _read(_artifacts(path, "test_the_logging_fmu_low") / "trace.mcap")
    assert schemas["plant/log"][0] == "foxglove.Log"
    published = json.loads(
        resources.files("multicosim.trace").joinpath("foxglove", "Log.json").read_text()
    )
    validator = jsonschema.Draft202012Validator(published)
    for line in messages["plant/log"]:
        validator.validate(line)
    assert messages["plant/log"][0]["message"] == "injected event at t=0.5"
    assert messages["plant/log"][0]["name"] == "plant"
    assert "AssertionError: injected event at t=0.5" in output
    # The component's log, copied beside the trace.
    assert (
        "injected event at t=0.5"
        in (_artifacts(path, "test_the_logging_fmu_low") / "plant.log").read_text()
    )


def test_fidelity_markers_select_fmu_tests(failing_run: tuple[Path, str]) -> None:
    _, output = failing_run
    # The one marked for low only is deselected at medium, not skipped.
    assert "multicosim: 1 deselected at fidelity levels they never run at" in output
