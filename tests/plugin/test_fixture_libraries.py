"""Fixture libraries come through the ``multicosim.fixtures`` entry points, ours and others'.

Another package is installed the way pip installs one: its module and a ``.dist-info``
directory whose ``entry_points.txt`` names the module, in a directory on the inner session's
``sys.path`` (pytester's subprocess runs put their directory there), where
``importlib.metadata`` finds it as it finds any installed distribution.
"""

from __future__ import annotations

from importlib.metadata import entry_points

import pytest

from pytest_multicosim.libraries import ENTRY_POINTS

LIBRARY = '''
"""The fixtures of a boat simulator that is not part of multicosim."""

import pytest


@pytest.fixture
def boat_speed():
    """The boat's cruise speed."""
    return 3.0
'''

USES_IT = """
def test_cruise(boat_speed):
    assert boat_speed == 3.0


def test_too_slow(boat_speed):
    assert boat_speed > 5.0, "the boat is too slow"


def test_unrelated():
    assert False, "not a test of ours"
"""


def install(pytester: pytest.Pytester, entry_point: str, *, module: str = LIBRARY) -> None:
    """Install the distribution ``boat-testing`` with ``entry_point`` in the fixtures group."""
    pytester.makepyfile(boat_fixtures=module)
    dist_info = pytester.mkdir("boat_testing-0.1.dist-info")
    (dist_info / "METADATA").write_text("Metadata-Version: 2.1\nName: boat-testing\nVersion: 0.1\n")
    (dist_info / "entry_points.txt").write_text(f"[{ENTRY_POINTS}]\n{entry_point}\n")


def test_a_library_of_another_package_is_loaded(pytester: pytest.Pytester) -> None:
    install(pytester, "boat = boat_fixtures")
    pytester.makepyfile(test_boat=USES_IT)
    result = pytester.runpytest_subprocess()
    result.assert_outcomes(passed=1, failed=2)
    # Its fixtures are ours: a test using one gets the header line and the report section.
    result.stdout.fnmatch_lines(["multicosim: fidelity=low placement=default seed=0 *"])
    assert result.stdout.str().count("- multicosim -") == 1
    result.stdout.fnmatch_lines(["verdict: AssertionError: the boat is too slow*"])


def test_a_library_can_be_kept_out_like_any_plugin(pytester: pytest.Pytester) -> None:
    install(pytester, "boat = boat_fixtures")
    pytester.makepyfile(test_boat=USES_IT)
    result = pytester.runpytest_subprocess("-p", "no:boat_fixtures")
    result.assert_outcomes(errors=2, failed=1)
    result.stdout.fnmatch_lines(["*fixture 'boat_speed' not found*"])


def test_a_missing_library_names_the_package_that_names_it(pytester: pytest.Pytester) -> None:
    install(pytester, "gone = boat_fixtures_gone")
    pytester.makepyfile(test_nothing="def test_nothing(): pass")
    result = pytester.runpytest_subprocess()
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(
        [
            'ERROR: Error importing plugin "boat_fixtures_gone": *'
            f"(named by boat-testing's {ENTRY_POINTS} entry point 'gone')"
        ]
    )


def test_an_entry_point_must_name_a_module(pytester: pytest.Pytester) -> None:
    install(pytester, "boat = boat_fixtures:boat_speed")
    pytester.makepyfile(test_nothing="def test_nothing(): pass")
    result = pytester.runpytest_subprocess()
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["ERROR: 'boat_fixtures:boat_speed' is not a module: *"])
    assert "Traceback" not in result.stderr.str()


def test_our_libraries_are_registered_the_same_way() -> None:
    named = {ep.name: ep.value for ep in entry_points(group=ENTRY_POINTS)}
    assert {
        "rover": "pytest_multicosim.rover",
        "px4": "pytest_multicosim.px4",
        "ardupilot": "pytest_multicosim.ardupilot",
        "gps_noise": "pytest_multicosim.gps_noise",
        "fmi": "pytest_multicosim.fmi",
        "f16": "pytest_multicosim.f16",
    }.items() <= named.items()


def test_our_libraries_are_loaded(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_probe="""
        def test_probe(
            pytestconfig, rover_noise, px4_params, ardupilot_params, gps_noise, fmu, f16_initial
        ):
            for name in ("rover", "px4", "ardupilot", "gps_noise", "fmi", "f16"):
                assert pytestconfig.pluginmanager.has_plugin(f"pytest_multicosim.{name}")
        """
    )
    pytester.runpytest().assert_outcomes(passed=1)
