"""The MuJoCo world participant: physics state, a vehicle plug-in, lockstep stepping.

The world is split the dm_control way: :class:`Physics` holds the static ``MjModel`` and the
``MjData`` state and knows how to integrate up to a simulated time; a :class:`Vehicle`
(rover, quadrotor, ...) knows its MJCF model, reads actuator commands from topics and
publishes its sensors; :class:`World` is the participant that the scheduler steps every
``WorldConfig.period``.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from ..core.deps import require
from ..core.errors import ConfigurationError, MulticosimError, PhysicsDivergedError
from ..core.geo import GRAVITY, local_to_geodetic
from .config import WorldConfig, check_sensor_topics
from .obstacles import NO_OBSTACLES, Proximity
from .wind import Body

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from ..runtime.context import StepContext
    from ._surroundings import Surroundings

require("mujoco", "mujoco")
import mujoco  # noqa: E402 - after the check, which names the extra

__all__ = ["Bodied", "Physics", "Vehicle", "World", "load_model"]

log = logging.getLogger(__name__)

_INTEGRATORS = {
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}
_SOLVERS = {
    "Newton": mujoco.mjtSolver.mjSOL_NEWTON,
    "CG": mujoco.mjtSolver.mjSOL_CG,
    "PGS": mujoco.mjtSolver.mjSOL_PGS,
}


_DIVERGENCE = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


def _log_warning(message: str) -> None:
    log.warning("MuJoCo: %s", message)


def _route_warnings() -> None:
    # MuJoCo's default handler appends to MUJOCO_LOG.TXT in the working directory; send
    # its warnings to logging instead, unless the application installed its own handler.
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_log_warning)


class Physics:
    """An MJCF model and its state, configured by a :class:`WorldConfig`.

    ``step_to(t)`` integrates in one batched ``mj_step`` call up to simulated time ``t``
    (counted in whole MuJoCo steps, so the world never drifts from the scheduler's clock).
    """

    def __init__(self, model: Any, config: WorldConfig) -> None:
        self.model = model
        self.config = config
        opt = model.opt
        opt.timestep = config.timestep
        opt.integrator = _INTEGRATORS[config.integrator]
        opt.solver = _SOLVERS[config.solver]
        opt.iterations = config.iterations
        opt.magnetic[:] = config.magnetic_field
        opt.gravity[:] = (0.0, 0.0, -GRAVITY)
        _route_warnings()
        self.data = mujoco.MjData(model)
        self._steps = 0
        self._sensors: dict[str, slice] = {}
        self.proximity: Proximity = NO_OBSTACLES
        """The vehicle's clearances and collisions for the current state (set by the World)."""
        self.forward()

    @classmethod
    def from_xml_path(cls, path: str | os.PathLike[str], config: WorldConfig) -> Physics:
        """Load the MJCF model at ``path``."""
        return cls(load_model(path), config)

    @property
    def time(self) -> float:
        """Simulated time of the physics state (s), a whole number of steps."""
        return self._steps * self.config.timestep

    def step_to(self, time: float) -> int:
        """Integrate up to ``time`` (the nearest whole step); return the steps taken."""
        target = round(time / self.config.timestep)
        n = target - self._steps
        if n > 0:
            mujoco.mj_step(self.model, self.data, n)
            # mj_step leaves sensors computed for the state before its last step; bring
            # them up to the state that is about to be published.
            self.forward()
            self._steps = target
            self._check_divergence()
        return max(n, 0)

    def forward(self) -> None:
        """Recompute what follows from the state (positions, sensors) after it was set by hand."""
        mujoco.mj_forward(self.model, self.data)

    def _check_divergence(self) -> None:
        # On a NaN or huge value MuJoCo warns and silently resets the state; a run that
        # went on from there would report a teleported vehicle as if it were physics.
        warning = self.data.warning
        if any(warning[w].number for w in _DIVERGENCE):
            config = self.config
            raise PhysicsDivergedError(
                f"the simulation diverged before t={self.time:.4f} s (timestep="
                f"{config.timestep:g}, integrator={config.integrator}, solver={config.solver}, "
                f"iterations={config.iterations}): use a smaller timestep, an implicit "
                "integrator or more solver iterations"
            )

    def sensor(self, name: str) -> npt.NDArray[np.float64]:
        """The live values of sensor ``name`` (a view into ``sensordata``)."""
        index = self._sensors.get(name)
        if index is None:
            sensor_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, name)
            if sensor_id < 0:
                raise MulticosimError(f"the model has no sensor {name!r}")
            adr = int(self.model.sensor_adr[sensor_id])
            index = slice(adr, adr + int(self.model.sensor_dim[sensor_id]))
            self._sensors[name] = index
        return self.data.sensordata[index]  # type: ignore[no-any-return]

    def actuator(self, name: str) -> int:
        """The index of actuator ``name`` in ``data.ctrl``."""
        actuator_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        if actuator_id < 0:
            raise MulticosimError(f"the model has no actuator {name!r}")
        return int(actuator_id)

    def geodetic(self, east: float, north: float, up: float) -> tuple[float, float, float]:
        """(latitude, longitude, altitude) of a local ENU point, from the configured home."""
        return local_to_geodetic(self.config.home, east=east, north=north, up=up)


def load_model(path: str | os.PathLike[str]) -> Any:
    """The ``MjModel`` of the MJCF file at ``path``; MulticosimError if it cannot be loaded."""
    try:
        return mujoco.MjModel.from_xml_path(os.fspath(path))
    except ValueError as exc:
        raise MulticosimError(f"could not load the MJCF model {path}: {exc}") from exc


class Vehicle(Protocol):
    """The vehicle half of a world: its MJCF model, its actuators and its sensors.

    ``sensors`` maps each sensor name to its default topic; a ``WorldConfig.sensor_topics``
    entry moves it to another topic. The world calls ``load_model`` and ``setup`` once, then
    at every period ``actuate`` (apply the latest commands to ``data.ctrl``), integrates, and
    ``sense`` (publish what the sensors read now). Any class with these members is one: the
    shipped vehicles and a user's own alike (see the package docstring for an example).
    ``load_model`` may return an ``MjSpec`` instead of an ``MjModel``: the world then adds
    its obstacles to it before compiling it. A vehicle that flies among obstacles or in
    wind also describes its body (:class:`Bodied`).
    """

    @property
    def sensors(self) -> Mapping[str, str]:
        """Each sensor's name and default topic (a plain dict attribute will do)."""
        ...

    def load_model(self) -> Any:
        """The vehicle's ``MjModel``."""
        ...

    def setup(self, physics: Physics, ctx: StepContext, topics: Mapping[str, str]) -> None:
        """Subscribe to command topics; ``topics`` maps sensor names to their topics.

        It may also set the initial state (``physics.data.qpos``, ``qvel``): the world then
        computes the sensors for it before the first reading.
        """
        ...

    def actuate(self, physics: Physics, ctx: StepContext) -> None:
        """Apply the latest actuator commands."""
        ...

    def sense(self, physics: Physics, ctx: StepContext) -> None:
        """Publish the sensors' readings, stamped with ``ctx.time``."""
        ...


@runtime_checkable
class Bodied(Protocol):
    """A vehicle that describes its body to the world: for obstacles, clearances and drag."""

    @property
    def body(self) -> Body:
        """Its MuJoCo body, enclosing radius and drag (a plain attribute will do)."""
        ...


class World:
    """A participant that steps MuJoCo in lockstep with the simulation's clock.

    At each period it applies the commands received so far, integrates from the previous
    exchange up to now in one batch, and publishes the sensors for the new state, so the
    readings a controller gets at time ``t`` describe the world at ``t``.
    """

    def __init__(self, config: WorldConfig, vehicle: Vehicle) -> None:
        check_sensor_topics(config, vehicle.sensors)
        self.config = config
        self.vehicle = vehicle
        self.period = config.period
        self.physics: Physics | None = None
        self._start: float | None = None
        self._surroundings: Surroundings | None = None
        if config.obstacles or config.wind is not None:
            if not isinstance(vehicle, Bodied):
                field = "obstacles" if config.obstacles else "wind"
                raise ConfigurationError(
                    field,
                    getattr(config, field),
                    f"none for a vehicle that does not describe its body ({vehicle!r} has no "
                    "`body`: see physics.Bodied)",
                )
            from ._surroundings import Surroundings

            self._surroundings = Surroundings(config, vehicle.body)

    @property
    def topics(self) -> dict[str, str]:
        """The topic of each sensor, after remapping."""
        return {name: self.config.topic(name, t) for name, t in self.vehicle.sensors.items()}

    def setup(self, ctx: StepContext) -> None:
        """Load the model, let the vehicle subscribe (and set its initial state)."""
        model = self.vehicle.load_model()
        surroundings = self._surroundings
        if isinstance(model, mujoco.MjSpec):
            if surroundings is not None:
                surroundings.attach(model)
            model = model.compile()
        elif surroundings is not None and surroundings.placed:
            raise ConfigurationError(
                "obstacles",
                self.config.obstacles,
                "none for a vehicle whose load_model() returns a compiled MjModel (return "
                "an MjSpec so the world can add them)",
            )
        self.physics = physics = Physics(model, self.config)
        if surroundings is not None:
            surroundings.bind(model, ctx.seed, self.period)
        self.vehicle.setup(physics, ctx, self.topics)
        # The first readings are published before any step: they must describe the state
        # the vehicle may have just set.
        self.physics.forward()
        if surroundings is not None:
            physics.proximity = surroundings.measure(physics.model, physics.data, ctx.time)

    def step(self, ctx: StepContext) -> None:
        """Apply commands, integrate up to ``ctx.time``, publish sensors."""
        physics = self.physics
        assert physics is not None, "setup() was not called"
        if self._start is None:
            # The world may join a simulation whose clock already runs: its physics time
            # starts at zero when it is first stepped.
            self._start = ctx.time
        self.vehicle.actuate(physics, ctx)
        surroundings = self._surroundings
        if surroundings is None:
            physics.step_to(ctx.time - self._start)
        else:
            surroundings.blow(physics.model, physics.data, physics.time)
            physics.step_to(ctx.time - self._start)
            physics.proximity = surroundings.measure(physics.model, physics.data, ctx.time)
        self.vehicle.sense(physics, ctx)

    def close(self) -> None:
        """Release the model and state."""
        self.physics = None
