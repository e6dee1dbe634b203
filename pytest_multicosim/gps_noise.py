"""Fixtures of the GPS-noise scenario (registered by the multicosim plugin).

``gps_noise`` is a factory: each call puts a sensor injector into the PX4 or rover simulator
of the test (whichever of ``px4_simulator`` and ``rover_simulator`` it uses), between the
world and the firmware, at the test's fidelity and placement; on the ArduPilot simulators
(``ardupilot_copter_simulator``, ``ardupilot_rover_simulator``) the same models become
ArduPilot's own simulated sensor faults:

```python
@pytest.mark.fidelity("low", "medium")
def test_spoof(px4_simulator, gps_noise):
    gps_noise(spoof=attacks.Local(north=10.0), start=8.0)   # 10 m north from t = 8 s
    simulation = px4_simulator.start()
    result = simulation.firmware.send(config)
```

Call it before starting the simulator. Keyword arguments build the models (all share
``start`` and ``end``): ``std``/``mean`` (Gaussian noise), ``bias``, ``drift`` and
``drift_rate`` (random walk), ``spoof`` and ``ramp`` (a jump), ``dropout`` (no fix),
``delay`` (s); a position's values are given by name (``multicosim.attacks.Local``), a
body axis's as a tuple; ``models`` adds any [`multicosim.attacks`][multicosim.attacks] models as
they are. ``sensor`` picks another sensor (``"mag"``/``"magnetometer"``, ``"baro"``, ...). Heavy
imports happen inside the fixture.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from multicosim.ardupilot.faults import FaultsComponent
    from multicosim.attacks import InjectorComponent, Local, Model

    # A number for every axis, one per axis, or a position's axes by name.
    Vector = float | Sequence[float] | Local

__all__ = ["GpsNoise", "gps_noise"]

SCENARIOS = (
    "px4_simulator",
    "rover_simulator",
    "ardupilot_copter_simulator",
    "ardupilot_rover_simulator",
)


class GpsNoise:
    """The ``gps_noise`` factory: ``gps_noise(std=1.0, start=10.0, ...)``."""

    def __init__(self, request: pytest.FixtureRequest) -> None:
        self._request = request
        self.injectors: list[InjectorComponent | FaultsComponent] = []

    def _simulator(self) -> Any:
        used = [name for name in SCENARIOS if name in self._request.fixturenames]
        if len(used) != 1:
            from multicosim import ConfigurationError

            raise ConfigurationError(
                "gps_noise",
                used,
                f"a test that uses exactly one of the fixtures {', '.join(SCENARIOS)}",
            )
        return self._request.getfixturevalue(used[0])

    def __call__(
        self,
        std: Vector = 0.0,
        *,
        mean: Vector = 0.0,
        bias: Vector | None = None,
        drift: Vector | None = None,
        drift_rate: Vector = 0.0,
        spoof: Vector | None = None,
        ramp: float = 0.0,
        dropout: bool = False,
        delay: float | None = None,
        start: float = 0.0,
        end: float | None = None,
        sensor: str = "gps",
        on: str | None = None,
        models: Sequence[Model] = (),
    ) -> InjectorComponent | FaultsComponent:
        """Add an injector with these models; returns the added component."""
        from multicosim import attacks

        def vector(value: Vector) -> float | tuple[float, ...] | Local:
            if isinstance(value, int | float | attacks.Local):
                return value
            return tuple(value)

        window: dict[str, Any] = {"start": start, "end": end}
        built: list[Model] = [attacks.Gaussian(std=vector(std), mean=vector(mean), on=on, **window)]
        if bias is not None:
            built.append(attacks.Bias(offset=vector(bias), on=on, **window))
        if drift is not None:
            built.append(attacks.Drift(std=vector(drift), rate=vector(drift_rate), on=on, **window))
        if spoof is not None:
            built.append(attacks.Jump(offset=vector(spoof), ramp=ramp, on=on, **window))
        if dropout:
            built.append(attacks.Dropout(**window))
        if delay is not None:
            built.append(attacks.Delay(delay=delay, **window))
        component: InjectorComponent | FaultsComponent = attacks.inject(
            self._simulator(), sensor, [*built, *models]
        )
        self.injectors.append(component)
        return component


@pytest.fixture
def gps_noise(request: pytest.FixtureRequest) -> GpsNoise:
    """Factory adding a sensor injector to the test's PX4 or rover simulator (before start)."""
    return GpsNoise(request)
