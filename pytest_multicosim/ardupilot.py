"""Fixtures of the ArduPilot scenarios (registered by the multicosim plugin).

``ardupilot_copter_simulation`` and ``ardupilot_rover_simulation`` are started
[`multicosim.ardupilot.ArduPilotSimulation`][multicosim.ardupilot.ArduPilotSimulation] s, real
ArduCopter or ArduRover SITL on our MuJoCo worlds at the fidelity, placement and seed the options
and the ``fidelity`` marker select, stopped when the test ends whatever happens:

```python
@pytest.mark.fidelity("medium", "high")
def test_mission(ardupilot_copter_simulation):
    home = ardupilot_copter_simulation.home
    result = ardupilot_copter_simulation.firmware.send(ardupilot.Configuration([...]))
    assert result.completed
```

``ardupilot_copter_simulator`` / ``ardupilot_rover_simulator`` are the unstarted simulators
(add injectors, or ``gps_noise``, before starting them); ``ardupilot_params`` can be
overridden in a module or conftest. ArduPilot comes from ``--mcs-ardupilot-dir`` (its ini
twin, or ``MCS_ARDUPILOT_DIR``): a directory with ``bin/arducopter``, ``bin/ardurover`` and
``params/``; without one, the tests are skipped with the reason. ArduPilot flies the MuJoCo
world only: at low fidelity they are skipped too. With ``--mcs-placement=docker`` ArduPilot
runs in a container of an image built from that directory. Heavy imports happen inside the
fixtures.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

from .fidelity import deselect, fidelity_of
from .options import sourced
from .simulations import tracked

if TYPE_CHECKING:
    from multicosim.ardupilot import ArduCopter, ArduPilotSimulation, ArduRover
    from multicosim.physics import WorldConfig

__all__ = [
    "ardupilot_copter_simulation",
    "ardupilot_copter_simulator",
    "ardupilot_dir",
    "ardupilot_params",
    "ardupilot_rover_simulation",
    "ardupilot_rover_simulator",
    "ardupilot_world",
    "configured_dir",
]


def configured_dir(config: pytest.Config) -> str | None:
    """ArduPilot's SITL directory for this run: the option, its ini twin, the environment."""
    return sourced(config, "mcs_ardupilot_dir")


@pytest.fixture
def ardupilot_dir(request: pytest.FixtureRequest) -> str:
    """The configured ArduPilot SITL directory; skips the test with the reason if none is."""
    directory = configured_dir(request.config)
    if directory is None:
        pytest.skip(
            "no ArduPilot SITL configured: give --mcs-ardupilot-dir (a directory with "
            "bin/arducopter, bin/ardurover and params/, such as ArduPilot's build/sitl "
            "binaries with Tools/autotest/default_params) or MCS_ARDUPILOT_DIR"
        )
    return directory


@pytest.fixture
def ardupilot_params() -> dict[str, float]:
    """ArduPilot parameters set at boot (names as ArduPilot's: ``WPNAV_SPEED_UP``, ...)."""
    return {}


@pytest.fixture
def ardupilot_world() -> WorldConfig | None:
    """The world configuration of the ArduPilot simulators (None: the fidelity's default)."""
    return None


def _simulator(
    request: pytest.FixtureRequest,
    vehicle: str,
    fidelity: str,
    seed: int,
    simulations: Any,
    params: dict[str, float],
    world: WorldConfig | None = None,
) -> Any:
    from multicosim.ardupilot import ArduCopter, ArduRover

    if fidelity == "low":
        pytest.skip(
            "ArduPilot flies the MuJoCo world (medium, high fidelity); there is no low "
            "fidelity ArduPilot"
        )
    directory = request.getfixturevalue("ardupilot_dir")
    placement = request.getfixturevalue("mcs_placement")
    cls = ArduCopter if vehicle == "copter" else ArduRover
    simulator = cls(
        world,
        fidelity=fidelity,  # type: ignore[arg-type]  # validated by the simulator
        firmware_dir=directory,
        placement=placement,
        seed=seed,
        params=params,
    )
    return tracked(simulator, simulations)


@pytest.fixture
def ardupilot_copter_simulator(
    request: pytest.FixtureRequest,
    mcs_fidelity: str,
    mcs_seed: int,
    mcs_simulations: Any,
    ardupilot_params: dict[str, float],
    ardupilot_world: WorldConfig | None,
) -> ArduCopter:
    """An unstarted ArduCopter simulator; whatever it starts is stopped at teardown."""
    simulator: ArduCopter = _simulator(
        request,
        "copter",
        mcs_fidelity,
        mcs_seed,
        mcs_simulations,
        ardupilot_params,
        ardupilot_world,
    )
    return simulator


@pytest.fixture
def ardupilot_copter_simulation(ardupilot_copter_simulator: ArduCopter) -> ArduPilotSimulation:
    """A started ArduCopter simulation (world, ArduCopter, ground station); always stopped."""
    return ardupilot_copter_simulator.start()


@pytest.fixture
def ardupilot_rover_simulator(
    request: pytest.FixtureRequest,
    mcs_fidelity: str,
    mcs_seed: int,
    mcs_simulations: Any,
    ardupilot_params: dict[str, float],
    ardupilot_world: WorldConfig | None,
) -> ArduRover:
    """An unstarted ArduRover simulator; whatever it starts is stopped at teardown."""
    simulator: ArduRover = _simulator(
        request,
        "rover",
        mcs_fidelity,
        mcs_seed,
        mcs_simulations,
        ardupilot_params,
        ardupilot_world,
    )
    return simulator


@pytest.fixture
def ardupilot_rover_simulation(ardupilot_rover_simulator: ArduRover) -> ArduPilotSimulation:
    """A started ArduRover simulation (world, ArduRover, ground station); always stopped."""
    return ardupilot_rover_simulator.start()


_SIMULATORS = frozenset({"ardupilot_copter_simulator", "ardupilot_rover_simulator"})


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    # ArduPilot flies the MuJoCo world only: a low-fidelity run of it is no test at all.
    deselect(config, items, _at_low)


def _at_low(item: pytest.Item) -> bool:
    uses = _SIMULATORS & set(getattr(item, "fixturenames", ()))
    return bool(uses) and fidelity_of(item) == "low"


def pytest_report_header(config: pytest.Config) -> str | None:
    directory = configured_dir(config)
    if directory is None:
        return None
    return f"multicosim ardupilot: real ArduPilot SITL from {directory}"
