"""The simulations a test starts, and the guarantee that each one stops.

``SimulationRegistry`` knows every live simulation of the session (the ``atexit`` safety
net stops what is left); ``Simulations``, the ``mcs_simulations`` fixture, is one test's
view of it; ``tracked`` lets a fixture library hand out a simulator whose ``start`` is
recorded there. The fixture libraries (``pytest_multicosim.rover``, a package of yours) use
``tracked``; the reports read the view to save what its simulations logged.
"""

from __future__ import annotations

import contextlib
import logging
from typing import Any, Protocol, TypeVar

import pytest

from multicosim.core.errors import MulticosimError

__all__ = [
    "SimulationRegistry",
    "Simulations",
    "registry_key",
    "tracked",
    "view_key",
]

log = logging.getLogger(__name__)

SimT = TypeVar("SimT")
StartedT = TypeVar("StartedT", covariant=True)


class _Simulator(Protocol[StartedT]):
    def start(self) -> StartedT: ...


SimulatorT = TypeVar("SimulatorT", bound=_Simulator[Any])


class SimulationRegistry:
    """Simulations started for tests; each is stopped at teardown whatever happens."""

    def __init__(self) -> None:
        self._live: list[Any] = []

    def track(self, simulation: SimT) -> SimT:
        """Stop ``simulation`` at the end of the test (or of the run, on interruption)."""
        self._live.append(simulation)
        return simulation

    def start(self, simulator: Any) -> Any:
        """Start ``simulator`` and track its simulation."""
        return self.track(simulator.start())

    @property
    def live(self) -> list[Any]:
        """Simulations not yet stopped."""
        return list(self._live)

    def stop(self, simulations: list[Any]) -> None:
        """Stop ``simulations`` (newest first); raise every failure together."""
        from multicosim.local.simulation import stop_all

        steps = []
        for sim in reversed(simulations):
            if sim in self._live:
                self._live.remove(sim)
                steps.append((f"simulation {sim!r}", sim.stop))
        stop_all(steps, "the test's simulations")

    def stop_all(self) -> None:
        """Stop every live simulation, logging failures (used at exit)."""
        try:
            self.stop(list(self._live))
        except BaseException as exc:  # at exit nothing can be raised to a test any more
            log.warning("stopping leftover simulations failed: %r", exc)


class Simulations:
    """The ``mcs_simulations`` fixture: starts simulations and stops them when the test ends."""

    def __init__(self, registry: SimulationRegistry) -> None:
        self._registry = registry
        self.simulations: list[Any] = []

    def track(self, simulation: SimT) -> SimT:
        """Stop ``simulation`` when the test ends (and record it for the test's trace)."""
        self.simulations.append(self._registry.track(simulation))
        from multicosim import trace

        test_trace = trace.active()
        if test_trace is not None:
            # A simulation without a simulated clock has nothing to record.
            with contextlib.suppress(MulticosimError):
                test_trace.attach(simulation)
        return simulation

    def start(self, simulator: _Simulator[StartedT]) -> StartedT:
        """Start ``simulator`` and stop its simulation when the test ends."""
        return self.track(simulator.start())

    def close(self) -> None:
        """Stop the simulations of this test (newest first)."""
        self._registry.stop(self.simulations)


registry_key = pytest.StashKey[SimulationRegistry]()
"""Where ``config.stash`` keeps the session's ``SimulationRegistry``."""
view_key = pytest.StashKey[Simulations]()
"""Where an item's stash keeps its ``mcs_simulations`` view (read by the reports)."""


def tracked(simulator: SimulatorT, simulations: Simulations) -> SimulatorT:
    """``simulator`` itself, whose ``start`` hands each simulation to ``simulations``.

    The fixtures return the simulator itself, not a proxy, so that it is an instance of its
    own class; what it starts is stopped (and recorded) as the test ends.
    """
    start = simulator.start

    def start_tracked() -> Any:
        return simulations.track(start())

    # An instance attribute, not a method assignment: it shadows the class's own start.
    setattr(simulator, "start", start_tracked)  # noqa: B010
    return simulator
