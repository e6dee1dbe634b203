"""The Docker engine connection, the labels every resource carries, and their errors."""

from __future__ import annotations

import functools
import os
import socket
import uuid
from typing import Any

from ..core.deps import require
from ..core.errors import EngineUnavailableError, ImageMissingError
from ..local.rundirs import boot_id, start_time

require("docker", "docker")
import docker  # noqa: E402 - after the check, which names the extra
import docker.errors  # noqa: E402
from docker.errors import APIError, ImageNotFound, NotFound  # noqa: E402

__all__ = [
    "LABEL_COMPONENT",
    "LABEL_OWNER",
    "LABEL_RUN",
    "LABEL_SESSION",
    "APIError",
    "ImageNotFound",
    "NotFound",
    "client",
    "labels",
    "owner_alive",
    "owner_id",
    "require_image",
    "session_id",
]

# APIError, NotFound and ImageNotFound (imported above) are the SDK's exceptions for the
# other modules, which must not import the SDK before this module has turned its absence
# into a DependencyMissingError.

LABEL_RUN = "multicosim.run"
LABEL_SESSION = "multicosim.session"
LABEL_OWNER = "multicosim.owner"
LABEL_COMPONENT = "multicosim.component"  # on containers: the component's name

_START_HINT = (
    "start it with `sudo setsid nohup dockerd >/tmp/dockerd.log 2>&1 </dev/null &` "
    "(or `sudo systemctl start docker`); `.ci/docker.sh` installs and starts it"
)


def engine_url() -> str:
    """Where the Docker engine is looked for: ``DOCKER_HOST``, read now, or the usual socket."""
    return os.environ.get("DOCKER_HOST", "unix:///var/run/docker.sock")


@functools.cache
def _client_for(pid: int, url: str) -> Any:
    # One client (one connection pool) per process and engine address; the pid key makes a
    # forked child build its own instead of sharing sockets with its parent.
    if url.startswith("unix://"):
        # Probe the socket ourselves first: the SDK leaks its socket when the engine is
        # down, and a missing socket file deserves the plainest message.
        path = url.removeprefix("unix://")
        with socket.socket(socket.AF_UNIX) as probe:
            try:
                probe.connect(path)
            except PermissionError as exc:
                raise EngineUnavailableError(
                    f"no permission to use the Docker engine at {url}: run as root or add "
                    "this user to the 'docker' group"
                ) from exc
            except OSError as exc:
                raise EngineUnavailableError(
                    f"the Docker engine is not running (nothing answers at {url}: "
                    f"{exc.strerror}): {_START_HINT}"
                ) from exc
    try:
        return docker.DockerClient(base_url=url, version="auto", timeout=60)
    except docker.errors.DockerException as exc:
        text = str(exc)
        if "PermissionError" in text or "Permission denied" in text:
            raise EngineUnavailableError(
                f"no permission to use the Docker engine at {url}: run as root or add this "
                "user to the 'docker' group"
            ) from exc
        raise EngineUnavailableError(
            f"the Docker engine is not running (nothing answers at {url}): {_START_HINT}"
        ) from exc


def client() -> Any:
    """This process's Docker client for the engine named by ``DOCKER_HOST`` (read now)."""
    return _client_for(os.getpid(), engine_url())


def engine_available() -> str | None:
    """None if the engine answers, else the reason it does not."""
    try:
        client().ping()
    except (EngineUnavailableError, docker.errors.DockerException) as exc:
        _client_for.cache_clear()
        return str(exc)
    except OSError as exc:
        _client_for.cache_clear()
        return f"the Docker engine is not reachable at {engine_url()}: {exc}"
    return None


@functools.cache
def session_id() -> str:
    """A token naming this host process; every resource it creates carries it."""
    return uuid.uuid4().hex[:16]


@functools.cache
def _owner_for(pid: int) -> str:
    return f"{socket.gethostname()}/{boot_id()}/{pid}/{start_time(pid) or '?'}"


def owner_id() -> str:
    """``HOST/BOOT/PID/START``: who created a resource, precise enough to tell it is gone."""
    return _owner_for(os.getpid())


def owner_alive(owner: str) -> bool | None:
    """Whether the process named by ``owner`` still runs; None if it lives on another host."""
    try:
        host, boot, pid_text, start = owner.split("/")
        pid = int(pid_text)
    except ValueError:
        return None
    if host != socket.gethostname():
        return None
    if boot != boot_id():
        return False  # the machine rebooted since
    return start_time(pid) == start


def labels(run_id: str) -> dict[str, str]:
    """The labels that tie a container or network to its run and host process."""
    return {LABEL_RUN: run_id, LABEL_SESSION: session_id(), LABEL_OWNER: owner_id()}


def build_hint(image: str) -> str:
    """How to get ``image`` onto this machine."""
    return (
        f"build it locally: `multicosim images build` builds multicosim's images "
        f"(or `docker build -t {image} ...` for your own); multicosim never pulls images"
    )


def require_image(api: Any, image: str, name: str) -> None:
    """Raise ImageMissingError unless ``image`` exists locally."""
    try:
        api.inspect_image(image)
    except docker.errors.ImageNotFound:
        raise ImageMissingError(
            name, f"cannot start: image {image!r} is not present locally; {build_hint(image)}"
        ) from None
