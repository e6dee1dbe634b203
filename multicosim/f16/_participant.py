"""The F-16 participant: AeroBench's F-16 and GCAS autopilot, stepped on the simulated clock.

AeroBench's ``run_f16_sim`` flies a whole flight in one loop. The participant flies the same
loop one sample at a time: each step of the simulated clock (one AeroBench ``step``)
integrates up to the next sample time with AeroBench's derivative, lets the GCAS autopilot
decide there (restarting the integrator when its mode changes, as ``run_f16_sim`` does) and
publishes the state. A flight is therefore the one ``run_f16_sim`` computes, sample for
sample, wherever the participant runs.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.deps import require
from ..core.errors import MulticosimError
from ._aerobench import Models, load
from ._config import F16Config
from ._messages import F16State

if TYPE_CHECKING:
    from ..runtime.context import StepContext

__all__ = ["PROGRAM", "F16Participant", "aircraft"]

log = logging.getLogger(__name__)

PROGRAM = "multicosim.f16:aircraft"
"""The participant's factory (``multicosim participant multicosim.f16:aircraft``)."""


class F16Participant:
    """The F-16 with its GCAS autopilot, one AeroBench ``step`` per step of the clock.

    Publishes an [`F16State`][multicosim.f16._participant.F16State] on ``config.topic`` at every
    step, from the initial state at time 0 until ``config.duration``; it publishes nothing after
    that.

    Raises:
        ConfigurationError: where ``config.directory`` is not AeroBench's (on construction,
            in the process that flies it).
    """

    def __init__(self, config: F16Config, models: Models | None = None) -> None:
        self.config = config
        self.period = config.knobs.step
        self.models = models or load(config.directory)
        knobs = config.knobs
        # As AeroBench's GCAS example builds it (the low-level controller's only gains).
        self.autopilot: Any = self.models.gcas(init_mode=config.gcas_mode, gain_str="old")
        state = np.zeros(13 + self.autopilot.llc.get_num_integrators())
        state[:13] = config.initial.vector()
        self._der = self.models.make_der_func(self.autopilot, knobs.model, False)
        if knobs.integrator == "rk45":
            self._integrator_class: Any = require("scipy.integrate", "f16").RK45
            self._integrator_kwargs: dict[str, Any] = {}
        else:
            self._integrator_class = self.models.euler
            self._integrator_kwargs = {"step": knobs.step}
        self.time = 0.0
        self.state = state
        # The mode may change at time 0, before the integrator starts (as in run_f16_sim).
        self.autopilot.advance_discrete_mode(self.time, self.state)
        self._integrator = self._integrator_at(self.time, self.state)
        self._dense: Any = None
        self._started = False
        self.finished = False
        """Whether the flight is over (its duration flown, or the autopilot finished)."""

    def _integrator_at(self, time: float, state: Any) -> Any:
        return self._integrator_class(
            self._der, time, state, self.config.duration, **self._integrator_kwargs
        )

    def setup(self, ctx: StepContext) -> None:
        """Nothing to subscribe to: the autopilot reads the F-16's own state."""

    def step(self, ctx: StepContext) -> None:
        """Publish the next sample (the initial state at the first step)."""
        if self.finished:
            return
        if not self._started:
            self._started = True
        elif not self._advance():
            self.finished = True
            return
        elif self.autopilot.is_finished(self.time, self.state):
            # run_f16_sim keeps the sample at which the autopilot finished, and no more.
            self.finished = True
        ctx.publish(self.config.topic, self.sample())

    def _advance(self) -> bool:
        """Integrate to the next sample time and let the autopilot decide there; False once
        the integration reached the flight's duration."""
        target = self.time + self.config.knobs.step
        integrator = self._integrator
        while integrator.t < target:
            if integrator.status != "running":
                if integrator.status == "failed":
                    raise MulticosimError(
                        f"AeroBench's {self.config.knobs.integrator} integration failed at "
                        f"t={integrator.t:g} s: {getattr(integrator, 'message', '')}"
                    )
                return False
            integrator.step()
            self._dense = None
        if self._dense is None:
            self._dense = integrator.dense_output()
        self.time = target
        self.state = self._dense(target)
        if self.autopilot.advance_discrete_mode(self.time, self.state):
            log.debug("GCAS mode %s at t=%g s", self.autopilot.mode, self.time)
            # A mode switch is a discontinuity of the derivative: integrate afresh from here.
            self._integrator = self._integrator_at(self.time, self.state)
            self._dense = None
        return True

    def sample(self) -> F16State:
        """The current state as the message it publishes."""
        x = self.state[:13].tolist()
        return F16State(
            time=self.time,
            altitude=x[11],
            airspeed=x[0],
            alpha=x[1],
            beta=x[2],
            roll=x[3],
            pitch=x[4],
            yaw=x[5],
            roll_rate=x[6],
            pitch_rate=x[7],
            yaw_rate=x[8],
            north=x[9],
            east=x[10],
            power=x[12],
            mode=str(self.autopilot.mode),
        )


def aircraft(config: F16Config) -> F16Participant:
    """Factory of the F-16 participant (for ``multicosim participant``)."""
    return F16Participant(config)
