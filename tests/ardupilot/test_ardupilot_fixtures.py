"""The ArduPilot fixture library, exercised through pytester as users would use it.

ArduPilot here is the stand-in program (``standin.py``): these check the fixtures, options
and reports, not the firmware.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from ardupilot_helpers import fake_ardupilot

import multicosim.ardupilot._simulator
import multicosim.ardupilot.vehicles  # noqa: F401

# The inner runs build MuJoCo worlds in this process; numpy cannot be loaded twice in one
# process, so the modules are loaded here, where pytester's module snapshot keeps them.

TEST_FILE = """
import pytest
import multicosim.ardupilot as ardupilot
import multicosim.attacks as attacks
from multicosim.ardupilot.faults import FaultsComponent

@pytest.mark.fidelity("low", "medium")
def test_copter(ardupilot_copter_simulation):
    assert isinstance(ardupilot_copter_simulation, ardupilot.ArduPilotSimulation)
    assert ardupilot_copter_simulation.home == ardupilot.Home()
    ardupilot_copter_simulation.advance(0.25)

@pytest.mark.fidelity("medium")
def test_rover_with_gps_noise(ardupilot_rover_simulator, gps_noise):
    faults = gps_noise(spoof=attacks.Local(north=5.0), start=1.0)
    assert isinstance(faults, FaultsComponent)
    assert faults.config.sensor == "gps"
    ardupilot_rover_simulator.start().advance(0.25)
"""


def test_without_ardupilot_the_tests_are_skipped_with_the_reason(
    pytester: pytest.Pytester,
) -> None:
    pytester.makepyfile(TEST_FILE)
    result = pytester.runpytest("--mcs-fidelity=medium", "-p", "no:cacheprovider", "-rs")
    result.assert_outcomes(skipped=2)
    result.stdout.fnmatch_lines(["*no ArduPilot SITL configured: give --mcs-ardupilot-dir*"])


@pytest.mark.parametrize("where", ["option", "ini", "environment"])
def test_the_directory_comes_from_the_option_its_ini_twin_or_the_environment(
    pytester: pytest.Pytester, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    directory = fake_ardupilot(tmp_path / "ardupilot")
    pytester.makepyfile(TEST_FILE)
    args = ["--mcs-fidelity=low,medium", "-p", "no:cacheprovider", "-rs"]
    if where == "option":
        args.append(f"--mcs-ardupilot-dir={directory}")
    elif where == "ini":
        pytester.makeini(f"[pytest]\nfilterwarnings = error\nmcs_ardupilot_dir = {directory}\n")
    else:
        monkeypatch.setenv("MCS_ARDUPILOT_DIR", str(directory))
    result = pytester.runpytest(*args)
    # Low fidelity is deselected (ArduPilot flies MuJoCo); medium runs on the stand-in.
    result.assert_outcomes(passed=2, deselected=2)
    result.stdout.fnmatch_lines(
        [
            f"multicosim ardupilot: real ArduPilot SITL from {directory}",
            "multicosim: 2 deselected at fidelity levels they never run at",
        ]
    )


def test_a_failing_test_keeps_arducopters_dataflash_log(
    pytester: pytest.Pytester, tmp_path: Path
) -> None:
    directory = fake_ardupilot(tmp_path / "ardupilot")
    artifacts = tmp_path / "artifacts"
    pytester.makepyfile(
        """
        import pytest

        @pytest.mark.fidelity("medium")
        def test_fails(ardupilot_copter_simulation):
            ardupilot_copter_simulation.advance(0.25)
            raise AssertionError("boom")
        """
    )
    result = pytester.runpytest(
        "--mcs-fidelity=medium",
        f"--mcs-ardupilot-dir={directory}",
        f"--mcs-artifacts={artifacts}",
        "-p",
        "no:cacheprovider",
    )
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        ["--- flight log 00000001.BIN*", "(DataFlash log: open it in MAVExplorer*"]
    )
    kept = list(artifacts.glob("**/00000001.BIN"))
    assert [p.read_bytes() for p in kept] == [b"stand-in DataFlash log"]
