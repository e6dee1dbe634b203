"""The F-16 participant's configuration, and the fidelity levels as AeroBench's own knobs.

AeroBench's simulation has three knobs (``run_f16_sim``'s ``model_str``, ``integrator_str``
and ``step``, which the reference example exposes): the aerodynamic model, the integrator
and the step at which the autopilot decides and the state is sampled. Each fidelity level
sets all three:

=========  ===========  ==========  ========  =================================================
level      model        integrator  step      what it is
=========  ===========  ==========  ========  =================================================
low        ``morelli``  ``euler``   1/30 s    one derivative per step (AeroBench's fixed-step
                                              Euler, which diverges from 1/15 s)
medium     ``morelli``  ``rk45``    1/30 s    AeroBench's defaults, as its GCAS example and
                                              the ARCH-COMP benchmark run it
high       ``stevens``  ``rk45``    1/60 s    the wind-tunnel tables themselves (Stevens and
                                              Lewis), of which Morelli's model is a
                                              polynomial fit; the autopilot decides at 60 Hz
=========  ===========  ==========  ========  =================================================
"""

from __future__ import annotations

import math
from typing import Literal

import msgspec

from ..core.errors import ConfigurationError
from ..core.fidelity import Fidelity, check_fidelity
from ..core.messages import Message
from ._messages import GCAS_MODES, STATE_TOPIC, InitialState

__all__ = [
    "FIDELITY_KNOBS",
    "INTEGRATORS",
    "MODELS",
    "F16Config",
    "Integrator",
    "Knobs",
    "Model",
    "knobs_for",
]

Model = Literal["morelli", "stevens"]
Integrator = Literal["rk45", "euler"]
MODELS: tuple[Model, ...] = ("morelli", "stevens")
"""AeroBench's aerodynamic models: Morelli's polynomials, Stevens and Lewis's tables."""
INTEGRATORS: tuple[Integrator, ...] = ("rk45", "euler")
"""AeroBench's integrators: scipy's adaptive RK45 and its own fixed-step Euler."""

MAX_STEP = 0.1  # s: the autopilot decides at 10 Hz at least
MAX_DURATION = 3600.0  # s: what a flight records grows with it


class Knobs(Message):
    """AeroBench's knobs: aerodynamic ``model``, ``integrator`` and ``step`` (s).

    ``step`` is both the rate at which the GCAS autopilot decides and the state is sampled
    and, with ``euler``, the integration step (``rk45`` chooses its own steps in between).

    Raises:
        ConfigurationError: naming the knob outside its allowed values.
    """

    model: str = "morelli"
    integrator: str = "rk45"
    step: float = 1 / 30

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise ConfigurationError("model", self.model, f"one of {MODELS}")
        if self.integrator not in INTEGRATORS:
            raise ConfigurationError("integrator", self.integrator, f"one of {INTEGRATORS}")
        step = self.step
        if isinstance(step, bool) or not isinstance(step, int | float):
            raise ConfigurationError("step", step, f"0 < step <= {MAX_STEP} s")
        if not (math.isfinite(step) and 0 < step <= MAX_STEP):
            raise ConfigurationError("step", step, f"0 < step <= {MAX_STEP} s")


FIDELITY_KNOBS: dict[Fidelity, Knobs] = {
    "low": Knobs(model="morelli", integrator="euler", step=1 / 30),
    "medium": Knobs(model="morelli", integrator="rk45", step=1 / 30),
    "high": Knobs(model="stevens", integrator="rk45", step=1 / 60),
}
"""The knobs each fidelity level sets (see the module's table)."""


def knobs_for(
    fidelity: Fidelity,
    *,
    model: str | None = None,
    integrator: str | None = None,
    step: float | None = None,
) -> Knobs:
    """The knobs of ``fidelity``, with those given instead of the level's own."""
    level = FIDELITY_KNOBS[check_fidelity(fidelity)]
    return Knobs(
        model=level.model if model is None else model,
        integrator=level.integrator if integrator is None else integrator,
        step=level.step if step is None else step,
    )


class F16Config(Message):
    """What the F-16 participant flies: AeroBench's code directory, the initial state, the
    knobs, the flight's ``duration`` (s), the GCAS autopilot's initial mode and the topic
    its state is published on.

    ``directory`` is the directory that holds ``aerobench/``
    ([`AeroBench.code`][multicosim.f16.AeroBench.code]). ``gcas_mode`` is where the GCAS autopilot
    starts: ``"roll"`` (AeroBench's GCAS example and the ARCH-COMP benchmark: the recovery starts at
    once), or ``"standby"`` (it engages only once the nose is low below its 1000 ft flight deck).

    Raises:
        ConfigurationError: naming the field with a value outside what is allowed.
    """

    directory: str
    initial: InitialState = msgspec.field(default_factory=InitialState)
    knobs: Knobs = msgspec.field(default_factory=Knobs)
    duration: float = 15.0
    gcas_mode: str = "roll"
    topic: str = STATE_TOPIC

    def __post_init__(self) -> None:
        if not isinstance(self.directory, str) or not self.directory:
            raise ConfigurationError("directory", self.directory, "AeroBench's code directory")
        if not isinstance(self.initial, InitialState):
            raise ConfigurationError("initial", self.initial, "a multicosim.f16.InitialState")
        if not isinstance(self.knobs, Knobs):
            raise ConfigurationError("knobs", self.knobs, "a multicosim.f16.Knobs")
        duration = self.duration
        ok = not isinstance(duration, bool) and isinstance(duration, int | float)
        if not ok or not (math.isfinite(duration) and self.knobs.step <= duration <= MAX_DURATION):
            raise ConfigurationError(
                "duration", duration, f"step <= duration <= {MAX_DURATION:g} s"
            )
        if self.gcas_mode not in GCAS_MODES:
            raise ConfigurationError("gcas_mode", self.gcas_mode, f"one of {GCAS_MODES}")
        if not isinstance(self.topic, str) or not self.topic:
            raise ConfigurationError("topic", self.topic, "a non-empty topic name")
