"""Fixtures for FMUs (registered by the multicosim plugin).

``fmu`` is a factory of :class:`multicosim.fmi.FMU` components that run where the test's
fidelity and backend say: in-process at low fidelity, as a process at medium and high, in a
container (its image built first) with ``--mcs-backend=docker``. Its simulators and
simulations are stopped at teardown and recorded for the test's trace, whatever happens::

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

from .docker import require_docker
from .simulations import Simulations, tracked

if TYPE_CHECKING:
    from multicosim.docker import ContainerSimulator
    from multicosim.fmi import FMU, Where
    from multicosim.local import ProcessSimulator

__all__ = ["REFERENCE_FMUS_ENV", "FMUFactory", "fmu", "reference_fmus"]

REFERENCE_FMUS_ENV = "MCS_REFERENCE_FMUS"


class FMUFactory:
    """The ``fmu`` fixture: ``fmu(path, **options)`` is an FMU component for this test.

    Options are those of :class:`multicosim.fmi.FMU`; ``where`` defaults to what the
    test's fidelity and backend select (:attr:`where`).
    """

    def __init__(
        self,
        request: pytest.FixtureRequest,
        fidelity: str,
        backend: str,
        seed: int,
        simulations: Simulations,
    ) -> None:
        self._request = request
        self.fidelity = fidelity
        self.backend = backend
        self.seed = seed
        self._simulations = simulations
        self.made: list[FMU] = []

    @property
    def where(self) -> Where:
        """Where this test's FMUs run: a container on the docker backend, else in-process
        at low fidelity and as a process above."""
        if self.backend == "docker":
            return "container"
        return "in-process" if self.fidelity == "low" else "process"

    def __call__(self, path: str | os.PathLike[str], **options: Any) -> FMU:
        """An FMU component (checked against its model description now)."""
        from multicosim.fmi import FMU

        options.setdefault("where", self.where)
        if options["where"] == "container":
            require_docker()
            self._request.getfixturevalue("mcs_runtime_image")
        component = FMU(path, **options)
        self.made.append(component)
        return component

    def simulator(self) -> ProcessSimulator | ContainerSimulator:
        """A fresh simulator of the test's backend and seed; what it starts is stopped (and
        recorded) as the test ends."""
        if self.backend == "docker":
            require_docker()
            from multicosim.docker import ContainerSimulator

            inner: ProcessSimulator | ContainerSimulator = ContainerSimulator(seed=self.seed)
        else:
            from multicosim.local import ProcessSimulator

            inner = ProcessSimulator(seed=self.seed)
        return tracked(inner, self._simulations)

    def simulate(self, path: str | os.PathLike[str], *args: Any, **options: Any) -> Any:
        """:func:`multicosim.fmi.simulate` where this test's FMUs run, recorded for its trace."""
        from multicosim import fmi

        where = options.pop("where", self.where)
        if where == "container":
            require_docker()
            self._request.getfixturevalue("mcs_runtime_image")
        return fmi.simulate(path, *args, where=where, simulator=self.simulator(), **options)


@pytest.fixture
def fmu(
    request: pytest.FixtureRequest,
    mcs_fidelity: str,
    mcs_backend: str,
    mcs_seed: int,
    mcs_simulations: Simulations,
) -> FMUFactory:
    """Factory of FMU components at this test's fidelity and backend (see the module)."""
    return FMUFactory(request, mcs_fidelity, mcs_backend, mcs_seed, mcs_simulations)


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
