"""Fixtures of the PX4 scenario (registered by the multicosim plugin).

``px4_simulation`` is a started [`multicosim.px4.PX4Simulation`][multicosim.px4.PX4Simulation] at
the fidelity, placement and seed that the options and the ``fidelity`` marker select, stopped when
the test ends whatever happens:

```python
@pytest.mark.fidelity("low", "medium")
def test_mission(px4_simulation):
    result = px4_simulation.firmware.send(px4.Configuration([px4.Waypoint(...)]))
    assert result.completed
```

``px4_simulator`` is the unstarted [`multicosim.px4.PX4`][multicosim.px4.PX4] (add injectors before
starting it); ``px4_world`` (the world configuration) and ``px4_params`` can be overridden
in a module or conftest. With ``--mcs-placement=docker`` the world and the autopilot run as
containers of the runtime image (rebuilt first if the source changed); where no Docker
engine runs the test is skipped with the reason (a failure with ``MCS_REQUIRE_DOCKER=1``).

Real PX4 is the top of the fidelity ladder: with ``--mcs-px4-binary`` (a PX4 SITL ``px4``
binary) or ``--mcs-px4-image`` (an image from ``multicosim images build --px4-dir``), or
their ini twins and ``MCS_PX4_BINARY`` / ``MCS_PX4_IMAGE``, every test using these
fixtures also runs on real PX4 at medium and high fidelity (``px4_autopilot`` is then
parametrized: ``builtin`` and ``sitl``). ``px4_sitl`` gives the configured real PX4 to tests
that need it and skips them with the reason where none is configured.
Heavy imports happen inside the fixtures.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

from multicosim.core.fidelity import check_fidelity

from .fidelity import deselect
from .options import sourced
from .simulations import tracked

if TYPE_CHECKING:
    from multicosim.placement import Placement
    from multicosim.px4 import PX4, SITL, MuJoCo, PX4Simulation

__all__ = [
    "AUTOPILOTS",
    "RealPX4",
    "px4_autopilot",
    "px4_params",
    "px4_simulation",
    "px4_simulator",
    "px4_sitl",
    "px4_world",
    "real_px4",
]

AUTOPILOTS = ("builtin", "sitl")


class RealPX4:
    """Where a real PX4 SITL comes from: a ``px4`` binary, an image, or neither."""

    def __init__(self, image: str | None, binary: str | None) -> None:
        self.image = image or None
        self.binary = binary or None

    @property
    def configured(self) -> bool:
        """Whether any real PX4 is configured."""
        return bool(self.image or self.binary)

    def sitl(self) -> SITL:
        """The firmware for ``px4.PX4(firmware=...)``: the binary, the image, or both."""
        from multicosim.px4 import SITL

        return SITL(binary=self.binary, image=self.image)

    def __repr__(self) -> str:
        return f"RealPX4(image={self.image!r}, binary={self.binary!r})"


def real_px4(config: pytest.Config) -> RealPX4:
    """The real PX4 configured for this run (options, ini, environment)."""
    return RealPX4(
        sourced(config, "mcs_px4_image"),
        sourced(config, "mcs_px4_binary"),
    )


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    # With real PX4 configured, each test on the PX4 fixtures runs on both autopilots.
    if "px4_autopilot" not in metafunc.fixturenames:
        return
    if not real_px4(metafunc.config).configured:
        return
    metafunc.parametrize("px4_autopilot", AUTOPILOTS, scope="session")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    # Real PX4 flies the MuJoCo world only: a low-fidelity run of it is no test at all.
    deselect(config, items, _real_at_low)


def _real_at_low(item: pytest.Item) -> bool:
    params = _params(item)
    return params.get("px4_autopilot") == "sitl" and params.get("mcs_fidelity") == "low"


def _params(item: pytest.Item) -> dict[str, Any]:
    callspec = getattr(item, "callspec", None)
    return dict(callspec.params) if callspec is not None else {}


@pytest.fixture
def px4_autopilot(request: pytest.FixtureRequest) -> str:
    """Which autopilot the PX4 fixtures fly: ``builtin`` or ``sitl`` (real PX4)."""
    return str(getattr(request, "param", "builtin"))


@pytest.fixture
def px4_world() -> MuJoCo | None:
    """The world configuration of ``px4_simulator`` (None: ``px4.WorldConfig()`` defaults)."""
    return None


@pytest.fixture
def px4_params() -> dict[str, float]:
    """PX4 parameters given to the autopilot (names as PX4's: ``MPC_XY_CRUISE``, ...)."""
    return {}


@pytest.fixture
def px4_simulator(
    request: pytest.FixtureRequest,
    mcs_fidelity: str,
    mcs_placement: Placement,
    mcs_seed: int,
    mcs_simulations: Any,
    px4_world: MuJoCo | None,
    px4_params: dict[str, float],
    px4_autopilot: str,
) -> PX4:
    """An unstarted PX4 Simulator; whatever it starts is stopped at teardown."""
    from multicosim.core.errors import ConfigurationError
    from multicosim.px4 import PX4

    firmware = None
    if px4_autopilot == "sitl":
        if mcs_fidelity == "low":
            pytest.skip(
                "real PX4 flies the MuJoCo world (medium, high); low fidelity is the "
                "built-in autopilot's point mass"
            )
        firmware = real_px4(request.config).sitl()
    try:
        simulator = PX4(
            px4_world,
            fidelity=check_fidelity(mcs_fidelity),
            placement=mcs_placement,
            seed=mcs_seed,
            params=px4_params,
            firmware=firmware,
        )
    except ConfigurationError as exc:
        if firmware is None or exc.field != "firmware":
            raise
        # The real PX4 configured cannot run in this placement (an image, on this machine).
        pytest.skip(f"real PX4 as configured does not run here: {exc}")
    return tracked(simulator, mcs_simulations)


@pytest.fixture
def px4_simulation(px4_simulator: PX4) -> PX4Simulation:
    """A started PX4 simulation (world + autopilot + ground station); stopped at teardown."""
    return px4_simulator.start()


@pytest.fixture
def px4_sitl(request: pytest.FixtureRequest) -> RealPX4:
    """The configured real PX4 SITL; skips the test with the reason when none is configured."""
    real = real_px4(request.config)
    if not real.configured:
        pytest.skip(
            "no real PX4 SITL configured: give --mcs-px4-binary (PX4's SITL bin/px4, with "
            "etc/ beside bin/) or --mcs-px4-image (multicosim images build --px4-dir DIR)"
        )
    return real


def pytest_report_header(config: pytest.Config) -> str | None:
    real = real_px4(config)
    if not real.configured:
        return None
    source = real.binary or real.image
    return f"multicosim px4: real PX4 SITL {source} (the PX4 fixtures fly it too)"
