"""The model description is the contract: bad input is one clear ConfigurationError, named
field, value and what the FMU allows, raised before anything starts."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmu_helpers import sources_only

import multicosim as mcs
from multicosim import fmi


@pytest.fixture
def ball(reference_fmus: Path) -> Path:
    """BouncingBall, FMI 3: outputs h, v, h_ft; parameters g (fixed) and e (0.5..1)."""
    return reference_fmus / "fmi3" / "BouncingBall.fmu"


def _error(**options: object) -> mcs.ConfigurationError:
    with pytest.raises(mcs.ConfigurationError) as info:
        fmi.FMU(**options)  # type: ignore[arg-type]
    return info.value


def test_a_missing_fmu(tmp_path: Path) -> None:
    error = _error(path=tmp_path / "plant.fmu")
    assert error.field == "path"
    assert "an existing .fmu file" in error.allowed


def test_a_corrupt_fmu(tmp_path: Path) -> None:
    corrupt = tmp_path / "plant.fmu"
    corrupt.write_bytes(b"PK\x03\x04 this is no zip archive")
    error = _error(path=corrupt)
    assert error.field == "path"
    assert "an FMU (a zip with a modelDescription.xml)" in error.allowed


def test_an_invalid_model_description(ball: Path, tmp_path: Path) -> None:
    broken = tmp_path / "broken.fmu"
    with zipfile.ZipFile(ball) as source, zipfile.ZipFile(broken, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'causality="output"', b'causality="sideways"', 1)
            target.writestr(item, data)
    error = _error(path=broken)
    assert error.field == "path"
    assert "whose model description is valid" in error.allowed
    assert "sideways" in error.allowed


@pytest.mark.parametrize(
    ("field", "options", "listed"),
    [
        ("inputs", {"inputs": {"u": "cmd"}}, "causality input: none"),
        ("outputs", {"outputs": {"height": "h"}}, "h (Float64, m), v (Float64, m/s)"),
        ("parameters['k']", {"parameters": {"k": 1.0}}, "g (Float64, m/s2), e (Float64)"),
        ("record[0]", {"record": ["speed"]}, "der(h)"),
    ],
)
def test_an_unknown_variable_lists_those_of_its_causality(
    ball: Path, field: str, options: dict[str, object], listed: str
) -> None:
    error = _error(path=ball, **options)
    assert error.field == field
    assert listed in error.allowed


@pytest.mark.parametrize(
    ("field", "options", "said"),
    [
        ("inputs", {"inputs": {"h": "cmd"}}, "causality input, not output"),
        ("parameters['h']", {"parameters": {"h": 2.0}}, "not output"),
        ("start_values['e']", {"start_values": {"e": 0.8}}, "not parameter"),
        ("outputs", {"outputs": {"der(h)": "vz"}}, "named in record=(...)"),
        ("start_values['v_min']", {"start_values": {"v_min": 0.2}}, "cannot be set"),
    ],
)
def test_a_variable_of_the_wrong_causality(
    ball: Path, field: str, options: dict[str, object], said: str
) -> None:
    error = _error(path=ball, **options)
    assert error.field == field
    assert said in error.allowed


def test_a_local_is_published_once_it_is_recorded(ball: Path) -> None:
    component = fmi.FMU(ball, outputs={"der(h)": "vz"}, record=["der(h)"])
    assert component.plan.outputs == ((3, "vz"),)  # after h, v and h_ft


@pytest.mark.parametrize(
    ("options", "field", "allowed"),
    [
        ({"parameters": {"e": "bouncy"}}, "parameters['e']", "a number in [0.5, 1]"),
        ({"parameters": {"e": True}}, "parameters['e']", "a number in [0.5, 1]"),
        ({"start_values": {"h": [1.0, 2.0]}}, "start_values['h']", "a number"),
    ],
)
def test_a_value_of_the_wrong_type(
    ball: Path, options: dict[str, object], field: str, allowed: str
) -> None:
    error = _error(path=ball, **options)
    assert error.field == field
    assert error.allowed.startswith(allowed)


def test_a_value_outside_min_and_max(ball: Path) -> None:
    error = _error(path=ball, parameters={"e": 1.5})
    assert (error.field, error.value) == ("parameters['e']", 1.5)
    assert error.allowed == "a number in [0.5, 1], as e (Float64) declares"
    assert fmi.describe(ball).range("e") == (0.5, 1.0)


def test_integers_keep_to_their_type(reference_fmus: Path) -> None:
    feedthrough = reference_fmus / "fmi3" / "Feedthrough.fmu"
    error = _error(path=feedthrough, start_values={"Int8_input": 128})
    assert error.allowed.startswith("an integer in [-128, 127]")
    error = _error(path=feedthrough, start_values={"Int32_input": 1.5})
    assert error.allowed.startswith("an integer")


def test_an_array_of_the_wrong_size(reference_fmus: Path) -> None:
    error = _error(path=reference_fmus / "fmi3" / "StateSpace.fmu", parameters={"A": np.eye(2)})
    assert error.field == "parameters['A']"
    assert error.allowed.startswith("9 values (shape (3, 3))")


@pytest.mark.parametrize(
    ("period", "allowed"),
    [
        (0.15, "a multiple of 0.1 s, the fixed internal step of"),
        (0.0, "a positive number of seconds"),
        (float("nan"), "a positive number of seconds"),
        (1 / 3, "a whole number of nanoseconds"),
    ],
)
def test_a_period_the_fmu_cannot_step(reference_fmus: Path, period: float, allowed: str) -> None:
    # FMI 3 Dahlquist declares a fixed internal step of 0.1 s: with 0.15 s steps it would
    # silently answer at the wrong times (FMPy does not check it).
    error = _error(path=reference_fmus / "fmi3" / "Dahlquist.fmu", period=period)
    assert error.field == "period"
    assert allowed in error.allowed


def test_an_fmu_without_a_default_step_needs_a_period(reference_fmus: Path) -> None:
    error = _error(path=reference_fmus / "fmi2" / "Feedthrough.fmu")
    assert (error.field, error.value) == ("period", None)
    assert "states no default step" in error.allowed


def test_scheduled_execution_is_not_supported(reference_fmus: Path) -> None:
    error = _error(path=reference_fmus / "fmi3" / "Clocks.fmu")
    assert "scheduled execution is not supported" in error.allowed


def test_an_interface_the_fmu_lacks(reference_fmus: Path, tmp_path: Path) -> None:
    error = _error(path=reference_fmus / "fmi2" / "Dahlquist.fmu", interface="Scheduled")
    assert error.field == "interface"


def test_no_binary_for_this_platform_names_what_it_has(
    reference_fmus: Path, tmp_path: Path
) -> None:
    sources = sources_only(reference_fmus, tmp_path / "dahlquist")
    error = _error(path=sources)
    assert error.field == "path"
    assert f"a binary for this platform ({fmpy.platform})" in error.allowed
    assert "has binaries for: none" in error.allowed
    assert "compile=True builds a binary with FMPy" in error.allowed
    shutil.rmtree(sources / "sources")
    error = _error(path=sources)
    assert "no C sources to build one from" in error.allowed
    error = _error(path=sources, compile=True)
    assert error.field == "compile"


def test_compile_builds_the_binary_from_the_sources(reference_fmus: Path, tmp_path: Path) -> None:
    sources = sources_only(reference_fmus, tmp_path / "dahlquist")
    simulator = mcs.ProcessSimulator()
    node_id = simulator.add(fmi.FMU(sources, name="dahlquist", compile=True))
    with simulator.start() as simulation:
        simulation.advance(1.05)
        compiled = simulation.get(node_id).result()
        run_dir = simulation.run_dir
    shipped = fmi.simulate(reference_fmus / "fmi2" / "Dahlquist.fmu", stop_time=1.0)
    np.testing.assert_array_equal(compiled["x"], shipped["x"])
    assert not run_dir.exists()  # the compiled copy went with the run
    assert not (sources / "binaries").exists()  # the FMU given is left as it was


def test_nothing_starts_for_a_bad_configuration(ball: Path, no_leaks: None) -> None:
    simulator = mcs.ProcessSimulator()
    with pytest.raises(mcs.ConfigurationError):
        simulator.add(fmi.FMU(ball, placement="process", inputs={"x": "y"}))
    with pytest.raises(mcs.ConfigurationError, match="placement="):
        fmi.FMU(ball, placement="remote")
