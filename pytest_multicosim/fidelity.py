"""The ``fidelity`` marker and the parametrization of tests over the selected levels.

A test that asks for ``mcs_fidelity`` (or ``mcs_simulator``, ``mcs_fresh_simulation``, or a
fixture that does), or carries the marker, runs once per level that ``--mcs-fidelity``
selects, with the level in its id (``test_x[low]``). Levels its marker does not list are
deselected at collection, as ``-k`` deselects (one summary line counts them), so that a
skip always means something the test needed was missing. A misspelt marker is a collection
error naming the test.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from multicosim.core.fidelity import FIDELITIES

from .options import parse_fidelity, settings_key

__all__ = ["MARKER", "deselect", "deselected_key", "fidelity_of", "parametrize", "unlisted"]

MARKER = (
    "fidelity(*levels): run the test at these fidelity levels only (low, medium, high); "
    "deselected at the other selected levels"
)
"""The marker's line in ``pytest --markers``."""


# Fixtures whose tests run once per selected level.
_AWARE = frozenset({"mcs_fidelity", "mcs_simulator", "mcs_fresh_simulation"})


def _listed(metafunc: pytest.Metafunc) -> tuple[str, ...]:
    """The levels the test's marker allows (every level without a marker)."""
    marker = metafunc.definition.get_closest_marker("fidelity")
    if marker is None:
        return FIDELITIES
    # A collection error names the test and its marker without a traceback through pytest's
    # internals; the run stops like on any other collection error.
    args = ", ".join(map(repr, marker.args))
    where = f"@pytest.mark.fidelity({args}) on {metafunc.definition.nodeid}"
    if not marker.args or not all(isinstance(a, str) for a in marker.args):
        raise pytest.Collector.CollectError(
            f"{where}: give one or more levels as strings; allowed: {', '.join(FIDELITIES)}"
        )
    try:
        return parse_fidelity(",".join(marker.args), source=where)
    except pytest.UsageError as exc:
        raise pytest.Collector.CollectError(str(exc)) from None


def parametrize(metafunc: pytest.Metafunc) -> None:
    """Run the test once per selected level if it is fidelity-aware; else leave it alone."""
    marker = metafunc.definition.get_closest_marker("fidelity")
    wanted = _AWARE & set(metafunc.fixturenames)
    if marker is None and not wanted:
        return
    settings = metafunc.config.stash[settings_key]
    _listed(metafunc)  # a misspelt marker fails at collection, naming the test
    if "mcs_fidelity" not in metafunc.fixturenames:
        metafunc.fixturenames.append("mcs_fidelity")
    params = [pytest.param(level, id=level) for level in settings.fidelity]
    # Session scope: Hypothesis accepts it in @given tests (it is the same for every
    # example), and tests are grouped by level.
    metafunc.parametrize("mcs_fidelity", params, scope="session")


def fidelity_of(item: pytest.Item) -> str | None:
    """The level ``item`` runs at, if it is parametrized over levels."""
    callspec = getattr(item, "callspec", None)
    return None if callspec is None else callspec.params.get("mcs_fidelity")


deselected_key = pytest.StashKey[int]()
"""How many items ``deselect`` dropped in this session (the summary line counts them)."""


def deselect(
    config: pytest.Config, items: list[pytest.Item], never_runs: Callable[[pytest.Item], bool]
) -> None:
    """Deselect the items at a fidelity level they never run at (``never_runs``).

    They are reported to ``pytest_deselected`` (the summary's ``N deselected``), as ``-k``
    and ``-m`` report theirs, and counted for the plugin's own summary line.
    """
    kept: list[pytest.Item] = []
    dropped: list[pytest.Item] = []
    for item in items:
        (dropped if never_runs(item) else kept).append(item)
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = kept
        config.stash[deselected_key] = config.stash.get(deselected_key, 0) + len(dropped)


def unlisted(item: pytest.Item) -> bool:
    """Whether ``item`` runs at a level its ``fidelity`` marker does not list."""
    level = fidelity_of(item)
    marker = item.get_closest_marker("fidelity")
    if level is None or marker is None:
        return False
    # The marker was checked at collection (parametrize): its levels parse.
    return level not in parse_fidelity(",".join(marker.args))
