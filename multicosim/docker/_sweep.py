"""Remove the containers and networks of runs whose host process is gone.

Safe to call anywhere: without the Docker SDK or a running engine it does nothing and says
why. The pytest plugin calls it before the first test it acts for and at the end of that
session.
"""

from __future__ import annotations

import dataclasses
import logging

__all__ = ["SweepReport", "engine_available", "sweep"]

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class SweepReport:
    """What a sweep removed (container and network names), or why it was skipped."""

    containers: tuple[str, ...] = ()
    networks: tuple[str, ...] = ()
    skipped: str | None = None

    def summary(self) -> str:
        """One line for humans."""
        if self.skipped is not None:
            return f"docker sweep skipped: {self.skipped}"
        return (
            f"removed {len(self.containers)} leftover container(s) and "
            f"{len(self.networks)} network(s)"
        )


def engine_available() -> str | None:
    """None if a Docker engine answers, else the reason it does not (SDK or engine)."""
    try:
        from .engine import engine_available as check
    except ImportError as exc:
        return str(exc)
    return check()


def sweep(
    *, include_current_process: bool = False, only_current_process: bool = False
) -> SweepReport:
    """Remove every container and network labelled by a run whose host process has exited.

    ``include_current_process`` also removes what this process created (for the end of a
    session, when none of its simulations can still be running); ``only_current_process``
    removes just that, leaving other hosts' leftovers to the next session start (another
    test may be looking at them). Resources created by processes of other hosts sharing the
    engine are left alone.
    """
    reason = engine_available()
    if reason is not None:
        return SweepReport(skipped=reason)
    from .engine import (
        LABEL_OWNER,
        LABEL_RUN,
        LABEL_SESSION,
        APIError,
        NotFound,
        client,
        owner_alive,
        session_id,
    )
    from .node import _remove_container

    api = client().api
    mine = session_id()

    def stale(resource_labels: dict[str, str] | None) -> bool:
        found = resource_labels or {}
        if (include_current_process or only_current_process) and found.get(LABEL_SESSION) == mine:
            return True
        return not only_current_process and owner_alive(found.get(LABEL_OWNER, "")) is False

    containers: list[str] = []
    for info in api.containers(all=True, filters={"label": LABEL_RUN}):
        if stale(info.get("Labels")):
            try:
                _remove_container(api, info["Id"])
            except APIError as exc:
                log.warning("could not remove leftover container %s: %s", info["Id"][:12], exc)
                continue
            containers.append(info["Names"][0].lstrip("/") if info.get("Names") else info["Id"])
    networks: list[str] = []
    for info in api.networks(filters={"label": LABEL_RUN}):
        if stale(info.get("Labels")):
            try:
                api.remove_network(info["Id"])
            except NotFound:
                pass
            except APIError as exc:
                log.warning("could not remove leftover network %s: %s", info["Name"], exc)
                continue
            networks.append(info["Name"])
    if containers or networks:
        log.info("swept %d container(s), %d network(s)", len(containers), len(networks))
    return SweepReport(tuple(containers), tuple(networks))
