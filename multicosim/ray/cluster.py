"""Joining a Ray cluster: which address, the connection, and where its nodes reach us.

Ray is imported here, when a placement connects, never when the package is imported: a
run without the ``ray`` extra can still name the placement and be told what is missing.
"""

from __future__ import annotations

import importlib
import logging
import socket
from types import ModuleType
from typing import Any

from ..core.errors import ConfigurationError, PlacementUnavailableError

__all__ = [
    "CONNECT_TIMEOUT",
    "ENV_ADDRESS",
    "check_address",
    "connect",
    "driver_address",
    "node_ids",
]

log = logging.getLogger(__name__)

ENV_ADDRESS = "MCS_RAY_ADDRESS"
"""The cluster the registered ``ray`` placement joins (unset: a running one, else a new local
one)."""

CONNECT_TIMEOUT = 5.0
"""How long (s) the head node's address may take to accept a connection before joining."""

_ALLOWED = (
    "None, 'auto', 'local' or a cluster's HOST:PORT (its head node's address, as "
    "`ray start --head` prints it)"
)


def check_address(address: object, field: str = "address") -> str | None:
    """``address`` as given (stripped), or None; ConfigurationError naming ``field`` unless it
    is one this process can join as a driver on a node of the cluster."""
    if address is None:
        return None
    if not isinstance(address, str) or not address.strip():
        raise ConfigurationError(field, address, _ALLOWED)
    address = address.strip()
    if address.startswith("ray://"):
        raise ConfigurationError(
            field,
            address,
            f"{_ALLOWED}; a Ray Client address (ray://) runs this process off the cluster, "
            "where its nodes cannot reach the simulation's coordinator",
        )
    if address in ("auto", "local"):
        return address
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ConfigurationError(field, address, _ALLOWED)
    return address


def connect(address: str | None) -> ModuleType:
    """The ``ray`` module, connected to the cluster at ``address`` (see ``check_address``)
    unless this process is connected already (that connection is used as it is).

    PlacementUnavailableError where Ray is not installed or no cluster can be joined.
    """
    try:
        ray = importlib.import_module("ray")
    except ImportError as exc:
        raise PlacementUnavailableError(
            "Ray is not installed", f"pip install 'multicosim[ray]' ({exc})"
        ) from exc
    if ray.is_initialized():
        return ray
    if address not in (None, "auto", "local"):
        _check_reachable(address)
    kwargs: dict[str, Any] = {"address": address, "log_to_driver": False}
    if address in (None, "local"):
        kwargs["include_dashboard"] = False  # a local cluster, where one is started
    try:
        # configure_logging=False: a library leaves the logging handlers to its user.
        ray.init(configure_logging=False, **kwargs)
    except Exception as exc:  # Ray's ConnectionError, RuntimeError, ValueError, ...
        raise PlacementUnavailableError(
            f"no Ray cluster could be joined at {address or 'the default address'}",
            f"{type(exc).__name__}: {exc}".strip(),
        ) from exc
    log.info("joined the Ray cluster at %s", address or "the default address")
    return ray


def _check_reachable(address: str) -> None:
    # Ray retries an address that does not answer for a long time; a head node that is not
    # there is known at once.
    host, _, port = address.rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except OSError as exc:
        raise PlacementUnavailableError(
            f"no Ray cluster at {address}",
            f"nothing accepts connections there ({exc}); start one with `ray start --head` "
            "and give its address",
        ) from exc


def driver_address(ray: ModuleType) -> str:
    """The address of this process's node, as Ray knows it: where the other nodes reach it."""
    node_id = ray.get_runtime_context().get_node_id()
    for node in ray.nodes():
        if node.get("NodeID") == node_id and node.get("Alive"):
            return str(node["NodeManagerAddress"])
    return str(ray.util.get_node_ip_address())


def node_ids(ray: ModuleType) -> list[str]:
    """The ids of the cluster's live nodes."""
    return [str(node["NodeID"]) for node in ray.nodes() if node.get("Alive")]
