"""Real PX4 as a level of a falsifying search (``px4.sitl_level``).

What real PX4 confirms is tested in ``scenarios/test_search.py`` (it needs a PX4 binary);
here, how the level calls the search's simulate function, and its errors.
"""

from __future__ import annotations

from typing import Any

import pytest

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.search.falsify import Level, falsify

SITL = px4.SITL(image="multicosim/px4-sitl:0.1.0")


def test_the_level_runs_the_search_simulate_on_real_px4_at_medium_fidelity() -> None:
    calls: list[tuple[Any, str, int, px4.SITL | None]] = []

    def simulate(sample: Any, fidelity: str, seed: int, firmware: px4.SITL | None = None) -> Any:
        calls.append((sample, fidelity, seed, firmware))
        return {"time": [0.0, 1.0], "x": [sample["x"]] * 2}

    level = px4.sitl_level(simulate, SITL)
    assert isinstance(level, Level)
    assert level.name == px4.SITL_LEVEL == "px4-sitl"
    result = falsify(
        simulate, "always (x >= 0)", {"x": (-1.0, 1.0)}, optimizer="random", seed=4,
        levels=("low", "medium", level),
    )  # fmt: skip
    assert result.falsified
    assert result.levels == ("low", "medium", "px4-sitl")
    real = [c for c in calls if c[3] is not None]
    assert real == [(result.counterexample.example, "medium", 4, SITL)]  # type: ignore[union-attr]
    # The built-in autopilot runs every other simulation.
    assert all(c[3] is None for c in calls if c not in real)
    assert result.stats["px4-sitl"].runs == result.stats["px4-sitl"].tried == 1
    assert result.transfer_rates["px4-sitl"] == 1.0


def test_the_level_has_a_name_and_fidelity_of_its_own() -> None:
    seen: list[str] = []

    def simulate(sample: Any, fidelity: str, seed: int, *, firmware: Any = None) -> Any:
        seen.append(fidelity)
        return {"time": [0.0], "x": [1.0]}

    level = px4.sitl_level(simulate, SITL, name="px4-1.15", fidelity="high")
    assert level.name == "px4-1.15"
    assert level.simulate is not None
    level.simulate({}, "px4-1.15", 0)
    assert seen == ["high"]


def _simulate(sample: Any, fidelity: str, seed: int, firmware: Any = None) -> Any:
    return {}


@pytest.mark.parametrize(
    ("simulate", "firmware", "fidelity", "field"),
    [
        (lambda sample, fidelity, seed: {}, SITL, "medium", "simulate"),  # no firmware keyword
        ("not callable", SITL, "medium", "simulate"),
        (_simulate, "px4", "medium", "firmware"),
        (_simulate, SITL, "low", "fidelity"),  # real PX4 flies the MuJoCo world only
    ],
)
def test_bad_arguments_are_configuration_errors_naming_the_field(
    simulate: Any, firmware: Any, fidelity: Any, field: str
) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        px4.sitl_level(simulate, firmware, fidelity=fidelity)
    assert info.value.field == field
