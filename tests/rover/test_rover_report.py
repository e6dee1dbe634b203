"""A failing scenario test reports its component processes' output."""

from __future__ import annotations

import pytest


def test_failing_medium_rover_test_shows_component_logs(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        import pytest
        import multicosim.rover as rover

        @pytest.mark.fidelity("medium")
        def test_fails(rover_simulation):
            rover_simulation.controller.send(rover.Mission(speed=2.0, distance=0.5, wait=0.0,
                                                           final_distance=0.5))
            assert False, "on purpose"
        """
    )
    result = pytester.runpytest("--mcs-fidelity=medium", f"--mcs-artifacts={pytester.path}/art")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "*replay: * -m pytest *test_fails?medium?*",
            "*--- controller: last output (full log: *controller.log) ---*",
            "*serving Firmware('controller'*",
        ]
    )
    assert (pytester.path / "art").is_dir()
