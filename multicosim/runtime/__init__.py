"""The component API: what a component is written against, wherever it runs.

A *participant* is stepped every ``period`` of simulated time with a
[`StepContext`][multicosim.runtime.StepContext] (publish, subscribe, the simulated time, a seeded
random generator); a *firmware* ([`firmware`][multicosim.runtime.firmware]) is called with each
message sent to its node and advances the clock itself through its
[`FirmwareContext`][multicosim.runtime.FirmwareContext]. [`serve`][multicosim.runtime.serve.serve]
and [`run_participant`][multicosim.runtime.run_participant] run them as programs (``multicosim
serve`` / ``multicosim participant``), in a process or a container, over the wire protocol of
``multicosim.core.wire``.

* ``context``: StepContext, FirmwareContext, Subscription, the Participant protocol;
* ``transport``: the component side of the lockstep (ZeroMQ links, host watch);
* [`serve`][multicosim.runtime.serve.serve]: Firmware, the ``@firmware`` decorator, and component
  programs (``serve``, ``run_participant``, ``load_target``).
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
