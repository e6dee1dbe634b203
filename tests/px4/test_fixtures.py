"""The PX4 fixture library, exercised through pytester as users would use it."""

from __future__ import annotations

import pytest


def test_px4_simulation_is_stopped_even_when_the_test_fails(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        import pytest
        import multicosim.px4 as px4

        seen = []

        @pytest.mark.fidelity("low")
        def test_fails(px4_simulation):
            seen.append(px4_simulation)
            result = px4_simulation.firmware.send(
                px4.Configuration([px4.Waypoint(47.39790, 8.54570, 5.0)], end="hold")
            )
            assert result.completed, result.reason
            raise AssertionError("boom")

        def test_after():
            assert seen and seen[0].simulation.stopped
        """
    )
    result = pytester.runpytest("--mcs-fidelity=low", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*AssertionError: boom*"])


def test_high_fidelity_runs_our_autopilot_and_real_px4_needs_a_sitl(
    pytester: pytest.Pytester,
) -> None:
    pytester.makepyfile(
        """
        import multicosim.px4 as px4

        def test_sim(px4_simulator, px4_simulation):
            assert px4_simulator.world == px4.HIGH_FIDELITY_WORLD
            assert px4_simulation.firmware.autopilot is None  # a process at high fidelity
            px4_simulation.advance(0.5)

        def test_real(px4_sitl):
            pass
        """
    )
    result = pytester.runpytest("--mcs-fidelity=high", "-p", "no:cacheprovider", "-rs")
    result.assert_outcomes(passed=1, skipped=1)
    result.stdout.fnmatch_lines(["*no real PX4 SITL configured*"])
