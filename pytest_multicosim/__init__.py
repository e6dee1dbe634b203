"""The multicosim pytest plugin and its fixture libraries.

Installing multicosim activates the plugin (``pytest11`` entry point
``pytest_multicosim.plugin``): the ``--mcs-*`` options, the ``fidelity`` marker and the
``mcs_*`` fixtures; the fixture libraries (``rover``, ``px4``, ``ardupilot``, ``gps_noise``,
and other packages') come through the ``multicosim.fixtures`` entry points.
``Simulations`` is the type of the ``mcs_simulations`` fixture, for annotations.
"""

from __future__ import annotations

from .simulations import Simulations

__all__ = ["Simulations"]
