"""Fixture libraries: modules of fixtures that the plugin registers, ours and other packages'.

A library is a module named in the ``multicosim.fixtures`` entry-point group; the plugin
registers each as a pytest plugin (``-p no:MODULE`` keeps one out), and a test that uses one
of its fixtures is a test of ours (header line, traces, report section). multicosim's own
scenarios are registered this way (``pytest_multicosim.rover``, ``.px4``, ``.ardupilot``,
``.gps_noise``); a package of yours adds one in its ``pyproject.toml``:

```toml
[project.entry-points."multicosim.fixtures"]
boat = "boat_testing.fixtures"
```

A library should import heavy dependencies inside its fixtures, so that loading it (in every
pytest session of the environment) costs nothing.
"""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint, entry_points
from types import ModuleType

import pytest

__all__ = ["ENTRY_POINTS", "load"]

ENTRY_POINTS = "multicosim.fixtures"
"""The entry-point group that names fixture libraries."""


def load(config: pytest.Config) -> list[ModuleType]:
    """Register every fixture library the group names; return those now registered."""
    manager = config.pluginmanager
    loaded: dict[str, ModuleType] = {}
    for ep in entry_points(group=ENTRY_POINTS):
        if ep.attr:
            raise pytest.UsageError(
                f"{ep.value!r} is not a module: a fixture library is named by its module, "
                f"without ':attribute' ({_named_by(ep)})"
            )
        already = sys.modules.get(ep.module)
        if already is not None and not manager.is_blocked(ep.module):
            # A conftest imported it first (``from pytest_multicosim.px4 import ...``): pytest
            # can no longer rewrite its asserts (it would warn), and has no need to.
            if manager.get_plugin(ep.module) is None:
                manager.register(already, ep.module)
            loaded[ep.module] = already
            continue
        try:
            manager.import_plugin(ep.module)
        except pytest.UsageError as exc:  # the module is nowhere to be found
            raise pytest.UsageError(f"{exc} ({_named_by(ep)})") from None
        except Exception as exc:  # the library (or what it imports) failed
            exc.add_note(_named_by(ep))
            raise
        module = manager.get_plugin(ep.module)  # None when blocked with -p no:MODULE
        if isinstance(module, ModuleType):
            loaded[ep.module] = module
    return list(loaded.values())


def _named_by(ep: EntryPoint) -> str:
    # Which installed package to fix or remove: the module's name alone may not tell.
    dist = ep.dist.name if ep.dist is not None else "an installed package"
    return f"named by {dist}'s {ENTRY_POINTS} entry point {ep.name!r}"
