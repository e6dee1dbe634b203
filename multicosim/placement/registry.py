"""The registry of placements: the ``multicosim.placements`` entry-point group.

Each entry point names a placement class (``module:Class``) under the name users choose it
by, as pytest plugins and Gymnasium environments are registered:

```toml
[project.entry-points."multicosim.placements"]
process = "multicosim.placement.local:LocalProcess"
```

A package of one's own adds a placement the same way; nothing else changes.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import TYPE_CHECKING, Any

from ..core.errors import ConfigurationError

if TYPE_CHECKING:
    from ..core.fidelity import Fidelity
    from .protocol import Placement

__all__ = [
    "ENTRY_POINTS",
    "as_placement",
    "default_placement",
    "get_placement",
    "placement_names",
    "resolve",
]

ENTRY_POINTS = "multicosim.placements"


def placement_names() -> tuple[str, ...]:
    """The names of the registered placements, sorted."""
    return tuple(sorted({ep.name for ep in entry_points(group=ENTRY_POINTS)}))


def _allowed() -> str:
    names = ", ".join(map(repr, placement_names())) or "none registered"
    return f"a registered placement ({names}; the {ENTRY_POINTS!r} entry points)"


def get_placement(name: str, field: str = "placement") -> Placement:
    """The placement registered as ``name`` (ConfigurationError listing the names if none)."""
    if not isinstance(name, str):
        raise ConfigurationError(field, name, _allowed())
    found = [ep for ep in entry_points(group=ENTRY_POINTS) if ep.name == name]
    if not found:
        raise ConfigurationError(field, name, _allowed())
    from .protocol import Placement

    placement: Any = found[0].load()()
    if not isinstance(placement, Placement):
        raise ConfigurationError(field, name, f"{_allowed()}: {found[0].value} is no Placement")
    return placement


def default_placement(fidelity: Fidelity) -> str:
    """Where components run unless told: this process at low fidelity (analytic models, no
    IPC), local processes above (MuJoCo worlds beside their autopilots, in lockstep)."""
    return "in-process" if fidelity == "low" else "process"


def resolve(
    placement: str | Placement | None, fidelity: Fidelity, field: str = "placement"
) -> Placement:
    """``placement`` as a Placement: a registered name, a Placement, or None (the
    fidelity's default, [`default_placement`][multicosim.placement.registry.default_placement])."""
    if placement is None:
        return get_placement(default_placement(fidelity), field)
    return as_placement(placement, field)


def as_placement(placement: str | Placement, field: str = "placement") -> Placement:
    """``placement`` as a Placement: a registered name or a Placement."""
    from .protocol import Placement

    if isinstance(placement, str):
        return get_placement(placement, field)
    if isinstance(placement, Placement):
        return placement
    raise ConfigurationError(field, placement, f"a Placement or {_allowed()}")
