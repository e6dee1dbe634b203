"""Fixtures of the F-16 scenario (registered by the multicosim plugin).

``aerobench`` is AeroBench's F-16 models ([`multicosim.f16.AeroBench`][multicosim.f16.AeroBench]),
from ``--mcs-aerobench-dir`` (its ini twin ``mcs_aerobench_dir``), else ``MCS_AEROBENCH_DIR``, else
``../shared/aerobench`` beside the project; a test that uses it is skipped, with the reason,
where there is none (and fails where a directory is named that is not AeroBench's).
``f16_simulation`` is a started [`multicosim.f16.F16Simulation`][multicosim.f16.F16Simulation] at
the fidelity, placement and seed the options and the ``fidelity`` marker select, stopped when the
test ends whatever happens; ``f16_initial`` (override it in a module or conftest) is where it
starts:

```python
@pytest.mark.fidelity("low", "medium")
def test_recovers(f16_simulation):
    flight = f16_simulation.fly()
    assert flight.lowest.altitude > 0
```

``f16_simulator`` is the unstarted [`multicosim.f16.F16`][multicosim.f16.F16]. Heavy imports happen
inside the fixtures.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from multicosim.core.fidelity import check_fidelity

from .options import sourced
from .simulations import tracked

if TYPE_CHECKING:
    from multicosim.f16 import F16, AeroBench, F16Simulation, InitialState
    from multicosim.placement import Placement

__all__ = [
    "aerobench",
    "configured_aerobench",
    "f16_initial",
    "f16_simulation",
    "f16_simulator",
]

_ENV = "MCS_AEROBENCH_DIR"


def configured_aerobench(config: pytest.Config) -> str | None:
    """AeroBench's directory as this run names it: the option, its ini twin, the environment."""
    return sourced(config, "mcs_aerobench_dir")


@pytest.fixture(scope="session")
def aerobench(request: pytest.FixtureRequest) -> AeroBench:
    """AeroBench's F-16 models (see the module); skips with the reason where there are none."""
    from multicosim.f16 import AeroBench

    named = configured_aerobench(request.config)
    if named is not None:
        return AeroBench(named)  # named on purpose: a wrong directory is an error, not a skip
    root = request.config.rootpath
    directory = root.parent / "shared" / "aerobench"
    if not (directory / "code" / "aerobench").is_dir():
        pytest.skip(
            f"no AeroBench at {directory} (beside {root}): give --mcs-aerobench-dir or "
            f"{_ENV} (a checkout of AeroBenchVVPython)"
        )
    return AeroBench(Path(directory))


@pytest.fixture
def f16_initial() -> InitialState | None:
    """Where ``f16_simulator`` starts (None:
    [`multicosim.f16.InitialState`][multicosim.f16.InitialState]'s default)."""
    return None


@pytest.fixture
def f16_simulator(
    mcs_fidelity: str,
    mcs_placement: Placement,
    mcs_seed: int,
    mcs_simulations: Any,
    aerobench: AeroBench,
    f16_initial: InitialState | None,
) -> F16:
    """An unstarted F-16 scenario; whatever it starts is stopped at teardown."""
    from multicosim.f16 import F16

    scenario = F16(
        fidelity=check_fidelity(mcs_fidelity),
        placement=mcs_placement,
        seed=mcs_seed,
        aerobench=aerobench,
        initial=f16_initial,
    )
    return tracked(scenario, mcs_simulations)


@pytest.fixture
def f16_simulation(f16_simulator: F16) -> F16Simulation:
    """A started F-16 scenario (``fly()`` flies it); stopped at teardown."""
    return f16_simulator.start()


def pytest_report_header(config: pytest.Config) -> str | None:
    directory = configured_aerobench(config)
    return None if directory is None else f"multicosim f16: AeroBench from {directory}"
