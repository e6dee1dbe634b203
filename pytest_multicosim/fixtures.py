"""The plugin's own ``mcs_*`` fixtures (registered by the plugin as a plugin of its own).

Settings (``mcs_settings``, ``mcs_fidelity``, ``mcs_placement``, ``mcs_seed``), simulations
that always stop (``mcs_simulations``, ``mcs_simulator``, ``mcs_fresh_simulation``), the
runtime image of the docker placement (``mcs_runtime_image``) and the campaign executor
(``mcs_campaign_executor``). Heavy imports happen inside the fixtures, so collecting a suite
costs nothing.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import pytest

from ._signals import SigtermAsInterrupt
from .docker import prepared, runtime_image
from .options import Settings, settings_key
from .simulations import Simulations, registry_key, tracked, view_key

if TYPE_CHECKING:
    from multicosim.local import LocalSimulatorBase
    from multicosim.placement import Placement

__all__ = [
    "mcs_campaign_executor",
    "mcs_fidelity",
    "mcs_fresh_simulation",
    "mcs_placement",
    "mcs_runtime_image",
    "mcs_seed",
    "mcs_settings",
    "mcs_simulations",
    "mcs_simulator",
    "sigterm_key",
]

sigterm_key = pytest.StashKey[SigtermAsInterrupt]()
"""Where ``config.stash`` keeps the session's SIGTERM handler (installed on first use)."""


@pytest.fixture(scope="session")
def mcs_settings(request: pytest.FixtureRequest) -> Settings:
    """The validated multicosim options of this run."""
    return request.config.stash[settings_key]


@pytest.fixture
def mcs_fidelity(request: pytest.FixtureRequest) -> str:
    """The fidelity level this test runs at (tests run once per selected level)."""
    return str(getattr(request, "param", request.config.stash[settings_key].fidelity[0]))


@pytest.fixture
def mcs_placement(
    request: pytest.FixtureRequest, mcs_settings: Settings, mcs_fidelity: str
) -> Placement:
    """Where this test's components run: ``--mcs-placement``, else its fidelity's default
    (``in-process`` at low, ``process`` above), made ready (the docker placement's runtime
    image built). Skips, with the reason, where that placement cannot run here (a failure
    with ``MCS_REQUIRE_<PLACEMENT>=1``, e.g. ``MCS_REQUIRE_DOCKER=1``)."""
    from multicosim.core.fidelity import check_fidelity
    from multicosim.placement import resolve

    placement = resolve(mcs_settings.placement, check_fidelity(mcs_fidelity))
    return prepared(placement, request.config)


@pytest.fixture(scope="session")
def mcs_seed(mcs_settings: Settings) -> int:
    """The seed that fixes every random source of this test's simulations."""
    return mcs_settings.seed


@pytest.fixture
def mcs_simulations(request: pytest.FixtureRequest) -> Iterator[Simulations]:
    """Starts simulations for the test and stops them at teardown, even after a failure.

    From the first use on, SIGTERM stops the run as Ctrl-C does, with teardown.
    """
    request.config.stash[sigterm_key].install()
    view = Simulations(request.config.stash[registry_key])
    request.node.stash[view_key] = view
    try:
        yield view
    finally:
        view.close()


@pytest.fixture(scope="session")
def mcs_runtime_image(request: pytest.FixtureRequest) -> str:
    """The runtime image that docker-backed scenarios run, rebuilt if the source changed.

    Skips (or, with ``MCS_REQUIRE_DOCKER=1``, fails) the test where no engine runs. An
    installed package cannot build it: it must then be present locally.
    """
    return runtime_image(request.config)


@pytest.fixture
def mcs_simulator(
    mcs_placement: Placement, mcs_seed: int, mcs_simulations: Simulations
) -> LocalSimulatorBase[Any]:
    """A fresh simulator of the test's placement, seeded; its simulation always stops."""
    return tracked(mcs_placement.simulator(seed=mcs_seed), mcs_simulations)


@pytest.fixture(scope="session")
def mcs_campaign_executor(mcs_settings: Settings) -> Iterator[Any]:
    """The executor campaigns use: the Ray cluster of ``--mcs-ray``, else the process pool.

    Pass it on: ``run_campaign(simulate, requirement, design, executor=mcs_campaign_executor)``.
    A Ray connection is made on first use and closed at the end of the session.
    """
    from multicosim.search.campaign import ProcessExecutor, RayExecutor

    if mcs_settings.ray is None:
        yield ProcessExecutor()
        return
    executor = RayExecutor(mcs_settings.ray)
    try:
        yield executor
    finally:
        executor.shutdown()


@pytest.fixture(scope="session")
def mcs_fresh_simulation() -> Any:
    """A new simulation per Hypothesis example, stopped when the example ends.

    Session-scoped on purpose: Hypothesis rejects function-scoped fixtures in ``@given``
    tests because they are not reset between examples:

    ```python
    @given(mission=rover.strategies.missions())
    def test_x(mcs_fresh_simulation, mission):
        with mcs_fresh_simulation(rover.Rover) as simulation: ...
    ```
    """
    from multicosim.search.strategies import FreshSimulations

    return FreshSimulations()
