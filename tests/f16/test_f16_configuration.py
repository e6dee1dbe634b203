"""Bad input to the F-16 is a ConfigurationError naming the field, before anything starts."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

import multicosim as mcs
import multicosim.f16 as f16
from multicosim.f16 import arch


def test_a_missing_directory_is_named(tmp_path: Path) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.AeroBench(tmp_path / "nowhere")
    assert info.value.field == "directory"
    assert "an existing directory" in info.value.allowed


def test_no_directory_at_all_names_the_environment_variable(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(f16.AEROBENCH_ENV, raising=False)
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.AeroBench()
    assert info.value.field == "directory"
    assert f16.AEROBENCH_ENV in info.value.allowed


def test_the_environment_variable_names_it(
    monkeypatch: pytest.MonkeyPatch, aerobench: f16.AeroBench, tmp_path: Path
) -> None:
    monkeypatch.setenv(f16.AEROBENCH_ENV, str(aerobench.root))
    assert f16.AeroBench().code == aerobench.code
    # Its code/ directory names it as well as the checkout does.
    assert f16.AeroBench(aerobench.code).code == aerobench.code
    monkeypatch.setenv(f16.AEROBENCH_ENV, str(tmp_path))
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.AeroBench()
    assert info.value.field == f16.AEROBENCH_ENV


def test_a_directory_without_the_models_says_what_is_missing(tmp_path: Path) -> None:
    package = tmp_path / "code" / "aerobench"
    package.mkdir(parents=True)
    (package / "run_f16_sim.py").write_text("")
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.AeroBench(tmp_path)
    assert info.value.field == "directory"
    assert "aerobench/util.py" in info.value.allowed
    assert "aerobench/run_f16_sim.py" not in info.value.allowed.split("missing:")[1]


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"altitude": 0.0}, "altitude"),
        ({"altitude": -5.0}, "altitude"),
        ({"altitude": 60_000.0}, "altitude"),
        ({"airspeed": 100.0}, "airspeed"),
        ({"airspeed": math.nan}, "airspeed"),
        ({"alpha": math.radians(60)}, "alpha"),
        ({"beta": -1.0}, "beta"),
        ({"roll": 4.0}, "roll"),
        ({"pitch": -2.0}, "pitch"),
        ({"yaw": math.inf}, "yaw"),
        ({"pitch_rate": 10.0}, "pitch_rate"),
        ({"north": math.nan}, "north"),
        ({"power": 101.0}, "power"),
        ({"roll": True}, "roll"),
    ],
)
def test_initial_state_outside_the_envelope(changes: dict[str, Any], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.InitialState(**changes)
    assert info.value.field == field


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"fidelity": "ultra"}, "fidelity"),
        ({"placement": "kubernetes"}, "placement"),
        ({"initial": {"roll": 0.5}}, "initial"),
        ({"duration": 0.0}, "duration"),
        ({"duration": 7200.0}, "duration"),
        ({"gcas_mode": "panic"}, "gcas_mode"),
        ({"model": "boeing"}, "model"),
        ({"integrator": "rk4"}, "integrator"),
        ({"step": 0.5}, "step"),
        ({"step": -1 / 30}, "step"),
    ],
)
def test_invalid_scenario_is_refused_before_anything_starts(
    aerobench: f16.AeroBench, nothing_left: None, kwargs: dict[str, Any], field: str
) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.F16(aerobench=aerobench, **kwargs)
    assert info.value.field == field


def test_the_scenario_names_a_bad_directory(tmp_path: Path, nothing_left: None) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        f16.F16("low", aerobench=tmp_path)
    assert info.value.field == "directory"


@pytest.mark.parametrize(
    ("sample", "field"),
    [
        ({"roll": 0.5, "pitch": -1.2, "yaw": -0.5}, "roll"),  # below 0.2 pi
        ({"roll": 0.8, "pitch": -1.0, "yaw": -0.5}, "pitch"),  # above -0.35 pi
        ({"roll": 0.8, "pitch": -1.2, "yaw": 0.0}, "yaw"),  # above -0.125 pi
        ({"roll": 0.8, "pitch": -1.2}, "yaw"),
        ([0.8, -1.2], "sample"),
    ],
)
def test_benchmark_inputs_outside_arch_comp_ranges(
    aerobench: f16.AeroBench, sample: Any, field: str
) -> None:
    benchmark = arch.Benchmark(aerobench)
    with pytest.raises(mcs.ConfigurationError) as info:
        benchmark(sample, "low", 0)
    assert info.value.field == field


def test_benchmark_altitude_and_component_fields(aerobench: f16.AeroBench) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        arch.Benchmark(aerobench, altitude=-1.0)
    assert info.value.field == "altitude"
    config = f16.F16Config(directory=str(aerobench.code))
    for kwargs, field in (
        ({"name": "no spaces"}, "name"),
        ({"placement": "nowhere"}, "placement"),
        ({"start_timeout": 0}, "start_timeout"),
    ):
        with pytest.raises(mcs.ConfigurationError) as info:
            f16.Aircraft(config, **kwargs)
        assert info.value.field == field


def test_fidelity_levels_set_aerobench_knobs() -> None:
    knobs = f16.FIDELITY_KNOBS
    assert (knobs["low"].model, knobs["low"].integrator) == ("morelli", "euler")
    # Medium is AeroBench's own default, as its GCAS example and ARCH-COMP run it.
    assert knobs["medium"] == f16.Knobs("morelli", "rk45", 1 / 30)
    assert (knobs["high"].model, knobs["high"].integrator) == ("stevens", "rk45")
    assert knobs["high"].step < knobs["medium"].step
    assert f16.knobs_for("high", step=0.02) == f16.Knobs("stevens", "rk45", 0.02)


def test_the_package_exports_what_it_means_to_and_loads_nothing_of_aerobench() -> None:
    assert set(f16.__all__) == {
        *("AEROBENCH_ENV", "F16", "FIDELITY_KNOBS", "GCAS_MODES", "INTEGRATORS", "MODELS"),
        *("PROGRAM", "STATE_TOPIC", "AeroBench", "Aircraft", "AircraftNode", "F16Config"),
        *("F16Participant", "F16Simulation", "F16State", "Flight", "InitialState"),
        *("Integrator", "Knobs", "Model", "aircraft", "knobs_for"),
    }
    probe = (
        "import sys, multicosim.f16, multicosim.f16.arch; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('scipy', 'aerobench')))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
