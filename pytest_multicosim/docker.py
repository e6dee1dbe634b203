"""The Docker engine as the plugin sees it: skip without one, build the runtime image, sweep.

Tests on the docker backend call :func:`require_docker` (the ``mcs_simulator`` and the
scenario fixtures do): without an engine they are skipped with the reason, or fail with
``MCS_REQUIRE_DOCKER=1`` (CI). Nothing here imports the Docker SDK before it is needed, so a
session that never uses the docker backend never loads it.
"""

from __future__ import annotations

import importlib.util
import logging
import os

import pytest

from multicosim.core.errors import MulticosimError

__all__ = ["docker_unavailable", "require_docker", "runtime_image", "sweep_containers"]

log = logging.getLogger(__name__)


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


def docker_unavailable(reason: str, detail: str = "") -> None:
    """Skip with the one-line ``reason``; fail, with ``detail``, under MCS_REQUIRE_DOCKER=1."""
    # Read when needed, not at import: a test may set it for a pytester run.
    if os.environ.get("MCS_REQUIRE_DOCKER") == "1":
        pytest.fail(f"MCS_REQUIRE_DOCKER=1 but {reason}: {detail}", pytrace=False)
    pytest.skip(reason)


def runtime_image() -> str:
    """The runtime image, rebuilt if the source changed; skips the test if there is none.

    An installed package cannot build it: it must then be present locally.
    """
    require_docker()
    from multicosim.docker import RUNTIME_IMAGE, build_images
    from multicosim.docker.engine import ImageNotFound, client

    try:
        return build_images()[0]
    except MulticosimError as exc:
        try:
            client().api.inspect_image(RUNTIME_IMAGE)
        except ImageNotFound:
            docker_unavailable(f"{RUNTIME_IMAGE} could not be built", str(exc))
        log.warning("using %s as it is: %s", RUNTIME_IMAGE, exc)
        return RUNTIME_IMAGE


def sweep_containers(*, only_current_process: bool = False) -> None:
    """Remove containers and networks that killed runs left (nothing without the SDK)."""
    if importlib.util.find_spec("docker") is None:
        return
    from multicosim.docker import sweep

    report = sweep(only_current_process=only_current_process)
    if report.containers or report.networks:
        log.warning("docker sweep: %s", report.summary())
