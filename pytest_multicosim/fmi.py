"""Fixtures for FMUs (registered by the multicosim plugin).

``fmu`` is a factory of [`multicosim.fmi.FMU`][multicosim.fmi.FMU] components that run where the
test's placement says: in-process at low fidelity, as a process at medium and high (the fidelity's
default), in a container (its image built first) with ``--mcs-placement=docker``. Its
simulators and simulations are stopped at teardown and recorded for the test's trace,
whatever happens:

```python
@pytest.mark.fidelity("low", "medium")
def test_plant(fmu):
    simulator = fmu.simulator()
    plant = simulator.add(fmu("plant.fmu", inputs={"u": "cmd"}, outputs={"y": "state"}))
    simulator.add(mcs.InProcessComponent(Controller, name="controller"))
    simulation = simulator.start()
    simulation.advance(10.0)
    result = simulation.get(plant).result()      # what fmpy.simulate_fmu returns

def test_ball(fmu):
    result = fmu.simulate("BouncingBall.fmu", stop_time=3.0, parameters={"e": 0.8})
```

A failing test's trace has one channel per FMU (its record, typed from the model
description, with units) and its log. ``reference_fmus`` is the directory of the Modelica
Association's Reference FMUs (``fmi2/``, ``fmi3/``, ``reference-results/``): the one
``MCS_REFERENCE_FMUS`` names, else ``../shared/reference-fmus`` beside the project; tests
that use it are skipped, with the reason, where there is none. Heavy imports happen inside
the fixtures.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from .simulations import Simulations, tracked

if TYPE_CHECKING:
    from multicosim.fmi import FMU
    from multicosim.local import LocalSimulatorBase
    from multicosim.placement import Placement

__all__ = ["REFERENCE_FMUS_ENV", "FMUFactory", "fmu", "reference_fmus"]

REFERENCE_FMUS_ENV = "MCS_REFERENCE_FMUS"


class FMUFactory:
    """The ``fmu`` fixture: ``fmu(path, **options)`` is an FMU component for this test.

    Options are those of [`multicosim.fmi.FMU`][multicosim.fmi.FMU]; ``placement`` defaults to the
    test's ([`placement`][pytest_multicosim.fmi.FMUFactory.placement]).
    """

    def __init__(
        self,
        placement: Placement,
        seed: int,
        simulations: Simulations,
    ) -> None:
        self.placement = placement
        """Where this test's FMUs run: ``--mcs-placement``, else the fidelity's default."""
        self.seed = seed
        self._simulations = simulations
        self.made: list[FMU] = []

    def __call__(self, path: str | os.PathLike[str], **options: Any) -> FMU:
        """An FMU component (checked against its model description now)."""
        from multicosim.fmi import FMU

        options.setdefault("placement", self.placement)
        component = FMU(path, **options)
        self.made.append(component)
        return component

    def simulator(self) -> LocalSimulatorBase[Any]:
        """A fresh simulator of the test's placement and seed; what it starts is stopped (and
        recorded) as the test ends."""
        return tracked(self.placement.simulator(seed=self.seed), self._simulations)

    def simulate(self, path: str | os.PathLike[str], *args: Any, **options: Any) -> Any:
        """``multicosim.fmi.simulate`` where this test's FMUs run, recorded for its trace."""
        from multicosim import fmi

        placement = options.pop("placement", self.placement)
        return fmi.simulate(path, *args, placement=placement, simulator=self.simulator(), **options)


@pytest.fixture
def fmu(
    mcs_placement: Placement,
    mcs_seed: int,
    mcs_simulations: Simulations,
) -> FMUFactory:
    """Factory of FMU components at this test's fidelity and placement (see the module)."""
    return FMUFactory(mcs_placement, mcs_seed, mcs_simulations)


@pytest.fixture(scope="session")
def reference_fmus(request: pytest.FixtureRequest) -> Path:
    """The Reference FMUs' directory (``MCS_REFERENCE_FMUS``, else ../shared/reference-fmus
    beside the project); skips with the reason where there is none."""
    named = os.environ.get(REFERENCE_FMUS_ENV)
    root = request.config.rootpath
    directory = Path(named) if named else root.parent / "shared" / "reference-fmus"
    if not (directory / "fmi2").is_dir() or not (directory / "fmi3").is_dir():
        where = f"{REFERENCE_FMUS_ENV}={named}" if named else f"{directory} (beside {root})"
        pytest.skip(f"no Reference FMUs at {where}: set {REFERENCE_FMUS_ENV} to their directory")
    return directory
