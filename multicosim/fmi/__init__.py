"""FMUs as components: any FMI 2.0 or 3.0 model beside firmware, on one clock, in pytest.

```python
from multicosim import fmi

result = fmi.simulate("BouncingBall.fmu", stop_time=3.0)   # what fmpy.simulate_fmu returns

plant = fmi.FMU("plant.fmu", name="plant", period=0.01, parameters={"e": 0.7},
                inputs={"u": "cmd"}, outputs={"y": "state"})
simulator.add(plant)
```

An FMU is a participant: every ``period`` of simulated time it takes the inputs that
arrived on its topics, publishes its outputs (and its record, on the topic named like it)
and steps (``doStep``; model exchange: FMPy's CVode or Euler). FMPy loads and runs the
FMU; its model description is the contract, checked before anything starts
([`describe`][multicosim.fmi.describe]). See docs/guides/fmi.md.

Modules: ``model`` (the model description), ``config`` (the checked configuration),
``instance`` (the FMI calls, through FMPy), ``participant`` (the stepped program),
``messages`` (record, values and log on topics), ``component`` (the component and
its node), ``build`` (a binary from the sources, the container image), ``simulate``,
``errors``.
"""

from __future__ import annotations

from .build import build_image
from .component import FMU, FMUNode
from .config import SOLVERS, FMUConfig, Solver
from .errors import FMUError
from .messages import LogLine
from .model import INTERFACES, Interface, Model, Variable, describe
from .participant import PROGRAM, FMUParticipant, participant
from .simulate import default_step, simulate

__all__ = [
    "FMU",
    "INTERFACES",
    "PROGRAM",
    "SOLVERS",
    "FMUConfig",
    "FMUError",
    "FMUNode",
    "FMUParticipant",
    "Interface",
    "LogLine",
    "Model",
    "Solver",
    "Variable",
    "build_image",
    "default_step",
    "describe",
    "participant",
    "simulate",
]

# Shown under the name users import it by (``multicosim.fmi.FMUError``), as multicosim's
# own errors are shown as ``multicosim.X``.
FMUError.__module__ = __name__
