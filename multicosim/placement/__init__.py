"""Where components run: placements behind one protocol, registered by name.

A placement ([`Placement`][multicosim.placement.Placement]) makes the simulator of a run and starts
each component where it belongs: ``in-process`` (the simulation's own process), ``process`` (local
processes in lockstep), ``docker`` (containers on the run's network), ``ray`` (actors on a Ray
cluster), or one a package of yours registers in the ``multicosim.placements`` entry-point group.
One setting chooses it everywhere (``placement=`` on scenarios and components,
``--mcs-placement``, a case file's ``placement``); None means the fidelity's default.

* ``protocol``: the protocol and the program descriptions it places;
* ``registry``: the names and [`resolve`][multicosim.placement.resolve];
* [`local`][multicosim.local]: the ``in-process`` and ``process`` placements;
* [`scenario`][multicosim.f16.arch.Benchmark.scenario]: [`Scenario`][multicosim.placement.Scenario],
  the base of the scenario simulators;
* [`firmware`][multicosim.firmware]: starting real firmware (SITL builds) with its bridges, as one.

Names load on first use, so that looking up a placement's name imports nothing heavy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports

_LAZY = {
    **dict.fromkeys(
        ("Endpoint", "FirmwareProgram", "ParticipantProgram", "Placement", "ProgramSpec"),
        ".protocol",
    ),
    **dict.fromkeys(
        (
            "ENTRY_POINTS",
            "as_placement",
            "default_placement",
            "get_placement",
            "placement_names",
            "resolve",
        ),
        ".registry",
    ),
    **dict.fromkeys(("Scenario", "ScenarioSimulation"), ".scenario"),
}

__all__ = [
    "ENTRY_POINTS",
    "Endpoint",
    "FirmwareProgram",
    "ParticipantProgram",
    "Placement",
    "ProgramSpec",
    "Scenario",
    "ScenarioSimulation",
    "as_placement",
    "default_placement",
    "get_placement",
    "placement_names",
    "resolve",
]

if TYPE_CHECKING:
    from .protocol import Endpoint, FirmwareProgram, ParticipantProgram, Placement, ProgramSpec
    from .registry import (
        ENTRY_POINTS,
        as_placement,
        default_placement,
        get_placement,
        placement_names,
        resolve,
    )
    from .scenario import Scenario, ScenarioSimulation

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
