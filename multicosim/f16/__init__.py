"""The F-16 of AeroBench with its ground collision avoidance (GCAS) autopilot, as a component.

AeroBench (AeroBenchVVPython, GPL-3.0) is not part of multicosim: it is loaded from the
directory its user names ([`AeroBench`][multicosim.f16.AeroBench], or ``MCS_AEROBENCH_DIR``), never
copied:

```python
import multicosim.f16 as f16

aerobench = f16.AeroBench("AeroBenchVVPython")
flight = f16.F16(fidelity="medium", aerobench=aerobench,
                 initial=f16.InitialState(roll=0.8, pitch=-1.2)).fly()
flight.lowest.altitude                  # ft
```

* [`F16`][multicosim.f16.F16] is the scenario (one flight at a fidelity, in a placement),
  [`Aircraft`][multicosim.f16.Aircraft] the component (the F-16 participant,
  [`PROGRAM`][multicosim.f16.PROGRAM], publishing [`F16State`][multicosim.f16.F16State] on
  [`STATE_TOPIC`][multicosim.f16.STATE_TOPIC] every step),
  [`FIDELITY_KNOBS`][multicosim.f16.FIDELITY_KNOBS] the levels as AeroBench's knobs;
* [`multicosim.f16.arch`][multicosim.f16.arch] is the ARCH-COMP falsification benchmark "F16".

See docs/how-to/aerobench.md.
"""

from __future__ import annotations

from ._aerobench import AEROBENCH_ENV, AeroBench
from ._component import Aircraft, AircraftNode
from ._config import (
    FIDELITY_KNOBS,
    INTEGRATORS,
    MODELS,
    F16Config,
    Integrator,
    Knobs,
    Model,
    knobs_for,
)
from ._messages import GCAS_MODES, STATE_TOPIC, F16State, Flight, InitialState
from ._participant import PROGRAM, F16Participant, aircraft
from ._scenario import F16, F16Simulation

__all__ = [
    "AEROBENCH_ENV",
    "F16",
    "FIDELITY_KNOBS",
    "GCAS_MODES",
    "INTEGRATORS",
    "MODELS",
    "PROGRAM",
    "STATE_TOPIC",
    "AeroBench",
    "Aircraft",
    "AircraftNode",
    "F16Config",
    "F16Participant",
    "F16Simulation",
    "F16State",
    "Flight",
    "InitialState",
    "Integrator",
    "Knobs",
    "Model",
    "aircraft",
    "knobs_for",
]
