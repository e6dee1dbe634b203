"""The F-16 scenario as a Simulator: one flight from given initial conditions, at a fidelity.

```python
import multicosim.f16 as f16

scenario = f16.F16(fidelity="medium", aerobench=f16.AeroBench("AeroBenchVVPython"),
                   initial=f16.InitialState(roll=0.8, pitch=-1.2))
with scenario.start() as simulation:
    flight = simulation.fly()          # 15 s of flight, one state per 1/30 s
flight.lowest.altitude
```

Fidelity picks AeroBench's knobs ([`FIDELITY_KNOBS`][multicosim.f16.FIDELITY_KNOBS]), the placement
where the F-16 flies (default: this process at low fidelity, a local process above; ``"docker"``: a
container of the runtime image with AeroBench mounted read-only). The participant is the same
program everywhere, so a flight is the same, sample for sample, in every placement.
"""

from __future__ import annotations

import os

from ..core.clock import NS, to_ns
from ..core.errors import ConfigurationError
from ..core.fidelity import Fidelity
from ..core.interfaces import NodeId
from ..local import ProcessSimulation
from ..placement import Placement, Scenario, ScenarioSimulation
from ._aerobench import AeroBench
from ._component import Aircraft, AircraftNode
from ._config import F16Config, knobs_for
from ._messages import Flight, InitialState

__all__ = ["F16", "F16Simulation"]

AIRCRAFT_NAME = "f16"


class F16Simulation(ScenarioSimulation):
    """A running F-16 scenario: [`fly`][multicosim.f16._scenario.F16Simulation.fly] flies it to the
    end and returns the flight."""

    def __init__(
        self,
        simulation: ProcessSimulation,
        aircraft_id: NodeId[AircraftNode],
        fidelity: Fidelity,
        placement: Placement,
        config: F16Config,
    ) -> None:
        super().__init__(simulation)
        self.fidelity: Fidelity = fidelity
        self.placement = placement
        self.config = config
        self._aircraft_id = aircraft_id

    @property
    def aircraft(self) -> AircraftNode:
        """The F-16's node (what it published so far: ``aircraft.flight()``)."""
        return self.simulation.get(self._aircraft_id)

    def fly(self) -> Flight:
        """Run the clock until the flight's duration is flown; the whole flight.

        Calling it again returns the same flight (the clock does not move any more).
        """
        config = self.config
        # The last sample falls within a step of the duration (its time is a sum of steps):
        # a step more than that, and the participant has seen its integration end.
        end_ns = to_ns(config.duration) + 2 * to_ns(config.knobs.step, field="step")
        remaining = end_ns - self.scheduler.now_ns
        if remaining > 0:
            self.simulation.advance(remaining / NS)
        return self.aircraft.flight(self.fidelity)

    def __repr__(self) -> str:
        return (
            f"F16Simulation(fidelity={self.fidelity!r}, placement={self.placement.name!r}, "
            f"time={self.time:g})"
        )


class F16(Scenario[F16Simulation]):
    """The F-16 scenario Simulator: AeroBench's F-16 with its GCAS autopilot, one flight.

    ``fidelity`` picks AeroBench's knobs (see [`FIDELITY_KNOBS`][multicosim.f16.FIDELITY_KNOBS];
    ``model``, ``integrator`` and ``step`` override the level's own); ``placement`` where the F-16
    flies (``"in-process"``, ``"process"``, ``"docker"``, ...; None: the fidelity's default);
    ``seed`` fixes every random source (AeroBench has none: a flight depends on its initial
    state and knobs alone). ``aerobench`` is where AeroBench is (an
    [`AeroBench`][multicosim.f16._scenario.AeroBench], a path, or None for ``MCS_AEROBENCH_DIR``);
    ``initial`` the initial state (default:
    [`InitialState`][multicosim.f16._scenario.InitialState]'s); ``duration`` the flight's length in
    seconds; ``gcas_mode`` the GCAS autopilot's initial mode. Everything is checked here, before
    anything starts.

    Raises:
        ConfigurationError: naming the field with an invalid value.
    """

    def __init__(
        self,
        fidelity: Fidelity = "medium",
        placement: str | Placement | None = None,
        seed: int = 0,
        *,
        aerobench: AeroBench | str | os.PathLike[str] | None = None,
        initial: InitialState | None = None,
        duration: float = 15.0,
        gcas_mode: str = "roll",
        model: str | None = None,
        integrator: str | None = None,
        step: float | None = None,
        realtime: float | None = None,
        run_dir: str | None = None,
    ) -> None:
        super().__init__(
            fidelity=fidelity, placement=placement, seed=seed, realtime=realtime, run_dir=run_dir
        )
        if initial is not None and not isinstance(initial, InitialState):
            raise ConfigurationError("initial", initial, "a multicosim.f16.InitialState or None")
        self.aerobench = aerobench if isinstance(aerobench, AeroBench) else AeroBench(aerobench)
        self.config = F16Config(
            directory=str(self.aerobench.code),
            initial=initial if initial is not None else InitialState(),
            knobs=knobs_for(self.fidelity, model=model, integrator=integrator, step=step),
            duration=duration,
            gcas_mode=gcas_mode,
        )
        self._aircraft_id = self._add_own(
            Aircraft(self.config, name=AIRCRAFT_NAME, placement=self.placement)
        )

    def start(self) -> F16Simulation:
        """Start the F-16 (and the components added); it flies as the clock runs."""
        return F16Simulation(
            self._start_simulation(),
            self._aircraft_id,
            self.fidelity,
            self.placement,
            self.config,
        )

    def fly(self) -> Flight:
        """Start, fly the whole flight, stop; the flight."""
        with self.start() as simulation:
            return simulation.fly()
