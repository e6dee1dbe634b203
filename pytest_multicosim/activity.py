"""Whether the plugin acts for a test, and the sweep it makes once when it first does.

The plugin is installed for every pytest run of an environment with multicosim in it, so it
keeps out of suites that do not use it: it acts for a test that uses one of its fixtures (or
a fixture library's) or the ``fidelity`` marker, and for every test once an ``--mcs-*``
option is given. Only then does it look for what killed runs left behind.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Iterable
from types import ModuleType

import pytest

from .docker import sweep_containers

__all__ = ["Activity", "activity_key", "acts_for", "fixture_names", "nested", "uses_ours"]

log = logging.getLogger(__name__)


@dataclasses.dataclass
class Activity:
    """Whether the plugin acts in this session, and what it has done once already."""

    explicit: bool  # an --mcs-* option was given: act for every test
    fixtures: frozenset[str]  # the fixtures we provide (a test using one is ours)
    swept: bool = False

    def sweep_once(self) -> None:
        """Remove what killed runs left (process groups, containers); once per session."""
        if self.swept:
            return
        self.swept = True
        from multicosim.local import sweep_stale_runs

        killed = sweep_stale_runs()
        if killed:
            log.warning("removed %d process group(s) left by killed runs", len(killed))
        if not nested():
            sweep_containers()


activity_key = pytest.StashKey[Activity]()
"""Where ``config.stash`` keeps the session's ``Activity``."""


def fixture_names(modules: Iterable[ModuleType]) -> frozenset[str]:
    """Names of the fixtures that ``modules`` define."""
    found: set[str] = set()
    for module in modules:
        for attr, value in vars(module).items():
            if type(value).__name__ == "FixtureFunctionDefinition":
                found.add(getattr(value, "name", None) or attr)
    return frozenset(found)


def acts_for(item: pytest.Item) -> bool:
    """Whether the plugin acts for ``item`` (our fixtures or marker, or an option given)."""
    return item.config.stash[activity_key].explicit or uses_ours(item)


def uses_ours(item: pytest.Item) -> bool:
    """Whether ``item`` uses one of our fixtures or the ``fidelity`` marker (a test of ours)."""
    if item.get_closest_marker("fidelity") is not None:
        return True
    fixtures = item.config.stash[activity_key].fixtures
    return not fixtures.isdisjoint(getattr(item, "fixturenames", ()))


def nested() -> bool:
    """Whether this session runs inside a test (pytester, inline or as a subprocess)."""
    # Such a session leaves the engine alone: the outer test may be looking at what a killed
    # run left on purpose.
    return os.environ.get("PYTEST_CURRENT_TEST") is not None
