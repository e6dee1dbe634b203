"""Fixtures of the Docker backend tests: a real engine and the current runtime image.

Without a reachable engine the tests are skipped with the reason, unless
``MCS_REQUIRE_DOCKER=1`` (CI), which turns that into a failure.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from pytest_multicosim.docker import docker_unavailable, require_docker


@pytest.fixture(scope="session")
def engine() -> Any:
    """The Docker client of this process; skips (or fails) without an engine."""
    require_docker()
    from multicosim.docker.engine import client

    return client()


@pytest.fixture(scope="session")
def image(engine: Any) -> str:
    """The runtime image, (re)built from the current source if it is stale."""
    from multicosim import MulticosimError
    from multicosim.docker import build_images

    try:
        return build_images()[0]
    except MulticosimError as exc:
        docker_unavailable("the runtime image could not be built", str(exc))
        raise  # unreachable: docker_unavailable skips or fails


@pytest.fixture(autouse=True)
def no_docker_leaks(
    request: pytest.FixtureRequest, no_docker_leak_check: Callable[[], None]
) -> Iterator[None]:
    """After each test that used the engine, nothing created by this process remains."""
    yield
    if "engine" in request.fixturenames:
        no_docker_leak_check()
