"""Placements as the plugin sees them: prepared before a test, skipped where they cannot run;
the Docker engine's runtime image and sweep.

Tests on a placement get it prepared (``prepared``; the ``mcs_placement`` fixture and the
scenario fixtures do): where it cannot run here (no Docker engine, say) they are skipped with
the reason, or fail with ``MCS_REQUIRE_<NAME>=1`` (``MCS_REQUIRE_DOCKER=1`` in CI). Nothing
here imports the Docker SDK before it is needed, so a session that never uses the docker
placement never loads it.
"""

from __future__ import annotations

import importlib.util
import logging
import os
from typing import TYPE_CHECKING, NoReturn

import pytest

from multicosim.core.errors import PlacementUnavailableError

if TYPE_CHECKING:
    from multicosim.placement import Placement

__all__ = [
    "docker_unavailable",
    "prepared",
    "prepared_key",
    "require_docker",
    "runtime_image",
    "sweep_containers",
    "unavailable",
]

log = logging.getLogger(__name__)


prepared_key = pytest.StashKey[dict[str, "PlacementUnavailableError | None"]]()
"""Where ``config.stash`` keeps, by placement name, None for a placement prepared in this
session, else why it cannot run (preparing docker's checks its image's source: once)."""


def prepared(placement: Placement, config: pytest.Config) -> Placement:
    """``placement``, prepared for a test (once per session); the test skips (or fails, see
    the module) where the placement cannot run here."""
    done = config.stash.setdefault(prepared_key, {})
    if placement.name not in done:
        try:
            placement.prepare()
            done[placement.name] = None
        except PlacementUnavailableError as exc:
            done[placement.name] = exc
    problem = done[placement.name]
    if problem is not None:
        unavailable(placement.name, str(problem), problem.detail)
    return placement


def unavailable(name: str, reason: str, detail: str = "") -> NoReturn:
    """Skip with the one-line ``reason``; fail, with ``detail``, under
    ``MCS_REQUIRE_<NAME>=1`` (the placement's name, upper case)."""
    variable = "MCS_REQUIRE_" + name.upper().replace("-", "_")
    # Read when needed, not at import: a test may set it for a pytester run.
    if os.environ.get(variable) == "1":
        pytest.fail(f"{variable}=1 but {reason}: {detail}", pytrace=False)
    pytest.skip(reason)


def require_docker() -> None:
    """Skip the test, with the reason, unless a Docker engine answers.

    With ``MCS_REQUIRE_DOCKER=1`` (CI) a missing engine fails the test instead.
    """
    try:
        from multicosim.docker import engine_available
    except ImportError as exc:  # the docker extra is missing (DependencyMissingError)
        docker_unavailable("no Docker SDK (pip install 'multicosim[docker]')", str(exc))
    reason = engine_available()
    if reason is not None:
        from multicosim.docker.engine import engine_url

        docker_unavailable(f"no Docker engine at {engine_url()}", reason)


def docker_unavailable(reason: str, detail: str = "") -> NoReturn:
    """Skip with the one-line ``reason``; fail, with ``detail``, under MCS_REQUIRE_DOCKER=1."""
    unavailable("docker", reason, detail)


def runtime_image(config: pytest.Config) -> str:
    """The runtime image, rebuilt if the source changed; skips the test if there is none.

    An installed package cannot build it: it must then be present locally.
    """
    from multicosim.docker import RUNTIME_IMAGE
    from multicosim.placement import get_placement

    prepared(get_placement("docker"), config)
    return RUNTIME_IMAGE


def sweep_containers(*, only_current_process: bool = False) -> None:
    """Remove containers and networks that killed runs left (nothing without the SDK)."""
    if importlib.util.find_spec("docker") is None:
        return
    from multicosim.docker import sweep

    report = sweep(only_current_process=only_current_process)
    if report.containers or report.networks:
        log.warning("docker sweep: %s", report.summary())
