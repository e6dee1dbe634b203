"""The ``fidelity`` marker and the parametrization of tests over the selected levels.

A test that asks for ``mcs_fidelity`` (or ``mcs_fresh_simulation``), or carries the marker,
runs once per level that ``--mcs-fidelity`` selects; levels its marker does not list are
skipped with the reason. A misspelt marker is a collection error naming the test.
"""

from __future__ import annotations

import pytest

from multicosim.core.fidelity import FIDELITIES

from .options import parse_fidelity, settings_key

__all__ = ["MARKER", "fidelity_of", "parametrize"]

MARKER = (
    "fidelity(*levels): run the test at these fidelity levels only (low, medium, high); "
    "skipped with the reason at the other selected levels"
)
"""The marker's line in ``pytest --markers``."""


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
    wanted = {"mcs_fidelity", "mcs_fresh_simulation"} & set(metafunc.fixturenames)
    if marker is None and not wanted:
        return
    settings = metafunc.config.stash[settings_key]
    listed = _listed(metafunc)
    if "mcs_fidelity" not in metafunc.fixturenames:
        metafunc.fixturenames.append("mcs_fidelity")
    params = [
        pytest.param(
            level,
            id=level,
            marks=()
            if level in listed
            else pytest.mark.skip(
                reason=f"fidelity {level!r} not in the test's levels ({', '.join(listed)})"
            ),
        )
        for level in settings.fidelity
    ]
    # Session scope: Hypothesis accepts it in @given tests (it is the same for every
    # example), and tests are grouped by level.
    metafunc.parametrize("mcs_fidelity", params, scope="session")


def fidelity_of(item: pytest.Item) -> str | None:
    """The level ``item`` runs at, if it is parametrized over levels."""
    callspec = getattr(item, "callspec", None)
    return None if callspec is None else callspec.params.get("mcs_fidelity")
