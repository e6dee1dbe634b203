"""The component API: what a component is written against, wherever it runs.

A *participant* is stepped every ``period`` of simulated time with a :class:`StepContext`
(publish, subscribe, the simulated time, a seeded random generator); a *firmware*
(:func:`firmware`) is called with each message sent to its node and advances the clock
itself through its :class:`FirmwareContext`. :func:`serve` and :func:`run_participant` run
them as programs (``multicosim serve`` / ``multicosim participant``), in a process or a
container, over the wire protocol of :mod:`multicosim.core.wire`.

* :mod:`.context`: StepContext, FirmwareContext, Subscription, the Participant protocol;
* :mod:`.transport`: the component side of the lockstep (ZeroMQ links, host watch);
* :mod:`.serve`: Firmware, the ``@firmware`` decorator, and component programs (``serve``,
  ``run_participant``, ``load_target``).
"""

from .context import FirmwareContext, Participant, StepContext, Subscription, derive_seed
from .serve import Firmware, firmware, load_target, run_participant, serve

__all__ = [
    "Firmware",
    "FirmwareContext",
    "Participant",
    "StepContext",
    "Subscription",
    "derive_seed",
    "firmware",
    "load_target",
    "run_participant",
    "serve",
]
