"""The MuJoCo world participant: physics state, a vehicle plug-in, lockstep stepping.

The world is split the dm_control way: [`Physics`][multicosim.physics.world.Physics] holds the
static ``MjModel`` and the ``MjData`` state and knows how to integrate up to a simulated time; a
[`Vehicle`][multicosim.physics.world.Vehicle] (rover, quadrotor, ...) knows its MJCF model, reads
actuator commands from topics and publishes its sensors; [`World`][multicosim.physics.world.World]
is the participant that the scheduler steps every ``WorldConfig.period``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol, cast, runtime_checkable

import numpy as np

from ..core.deps import require
from ..core.errors import ConfigurationError, MulticosimError, PhysicsDivergedError
from ..core.geo import GRAVITY, local_to_geodetic
from .config import WorldConfig, check_sensor_topics
from .encounter import CONTACTS_TOPIC, VehicleContact
from .fleet import CONTACT_GEOM, Pose, check_name, fleet_topic, member_names
from .obstacles import NO_OBSTACLES, Proximity
from .wind import Body

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..runtime.context import StepContext
    from ._surroundings import Surroundings

require("mujoco", "mujoco")
import mujoco  # noqa: E402 - after the check, which names the extra

__all__ = ["Bodied", "MemberPhysics", "Physics", "Vehicle", "World", "load_model", "load_spec"]

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
    """An MJCF model and its state, configured by a
    [`WorldConfig`][multicosim.physics.world.WorldConfig].

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

    prefix = ""
    """What the vehicle's names are prefixed with in the model ("": a world of one vehicle)."""

    @property
    def qpos(self) -> npt.NDArray[np.float64]:
        """The vehicle's joint positions (a view into ``data.qpos``)."""
        return self.data.qpos  # type: ignore[no-any-return]

    @property
    def qvel(self) -> npt.NDArray[np.float64]:
        """The vehicle's joint velocities (a view into ``data.qvel``)."""
        return self.data.qvel  # type: ignore[no-any-return]

    @property
    def ctrl(self) -> npt.NDArray[np.float64]:
        """The vehicle's actuator inputs (a view into ``data.ctrl``)."""
        return self.data.ctrl  # type: ignore[no-any-return]

    @property
    def sensordata(self) -> npt.NDArray[np.float64]:
        """The vehicle's sensor readings, in its model's order (a view into ``data.sensordata``)."""
        return self.data.sensordata  # type: ignore[no-any-return]

    def id(self, kind: Any, name: str) -> int:
        """The id of the vehicle's object ``name`` of ``kind`` (``mujoco.mjtObj.mjOBJ_SITE``,
        ...) in the model; MulticosimError if it has none."""
        found = int(mujoco.mj_name2id(self.model, kind, self.prefix + name))
        if found < 0:
            raise MulticosimError(
                f"the model has no {kind.name.removeprefix('mjOBJ_').lower()} "
                f"{self.prefix + name!r}"
            )
        return found

    def sensor(self, name: str) -> npt.NDArray[np.float64]:
        """The live values of the vehicle's sensor ``name`` (a view into ``sensordata``)."""
        index = self._sensors.get(name)
        if index is None:
            sensor_id = mujoco.mj_name2id(
                self.model, mujoco.mjtObj.mjOBJ_SENSOR, self.prefix + name
            )
            if sensor_id < 0:
                raise MulticosimError(f"the model has no sensor {self.prefix + name!r}")
            adr = int(self.model.sensor_adr[sensor_id])
            index = slice(adr, adr + int(self.model.sensor_dim[sensor_id]))
            self._sensors[name] = index
        return self.data.sensordata[index]  # type: ignore[no-any-return]

    def actuator(self, name: str) -> int:
        """The index of the vehicle's actuator ``name`` in ``data.ctrl`` (the whole model's)."""
        return self.id(mujoco.mjtObj.mjOBJ_ACTUATOR, name)

    def geodetic(self, east: float, north: float, up: float) -> tuple[float, float, float]:
        """(latitude, longitude, altitude) of a local ENU point, from the configured home."""
        return local_to_geodetic(self.config.home, east=east, north=north, up=up)


class MemberPhysics(Physics):
    """One vehicle's view of a world of several: the shared model and state, its objects by
    their own names (``prefix`` added), its own ``qpos``, ``qvel`` and ``ctrl``, its own
    proximity to the obstacles. Only the world integrates."""

    def __init__(
        self,
        world: Physics,
        prefix: str,
        qpos: slice,
        qvel: slice,
        ctrl: slice,
        sensordata: slice,
    ) -> None:
        # No second state: the view shares the world's model and data.
        self.model = world.model
        self.data = world.data
        self.config = world.config
        self.prefix = prefix
        self.proximity = NO_OBSTACLES
        self._world = world
        self._slices = (qpos, qvel, ctrl, sensordata)
        self._sensors = {}

    @property
    def time(self) -> float:
        """Simulated time of the physics state (s)."""
        return self._world.time

    @property
    def qpos(self) -> npt.NDArray[np.float64]:
        """The vehicle's joint positions (a view into ``data.qpos``)."""
        return self.data.qpos[self._slices[0]]  # type: ignore[no-any-return]

    @property
    def qvel(self) -> npt.NDArray[np.float64]:
        """The vehicle's joint velocities (a view into ``data.qvel``)."""
        return self.data.qvel[self._slices[1]]  # type: ignore[no-any-return]

    @property
    def ctrl(self) -> npt.NDArray[np.float64]:
        """The vehicle's actuator inputs (a view into ``data.ctrl``)."""
        return self.data.ctrl[self._slices[2]]  # type: ignore[no-any-return]

    @property
    def sensordata(self) -> npt.NDArray[np.float64]:
        """The vehicle's sensor readings, in its model's order (a view into ``data.sensordata``)."""
        return self.data.sensordata[self._slices[3]]  # type: ignore[no-any-return]

    def step_to(self, time: float) -> int:
        """Not a vehicle's to do: the world integrates every vehicle at once."""
        raise MulticosimError("a vehicle's view does not integrate: the world steps them all")

    def forward(self) -> None:
        """Recompute what follows from the state (the whole world's)."""
        self._world.forward()


def load_model(path: str | os.PathLike[str]) -> Any:
    """The ``MjModel`` of the MJCF file at ``path``; MulticosimError if it cannot be loaded."""
    try:
        return mujoco.MjModel.from_xml_path(os.fspath(path))
    except ValueError as exc:
        raise MulticosimError(f"could not load the MJCF model {path}: {exc}") from exc


def load_spec(path: str | os.PathLike[str]) -> Any:
    """The ``MjSpec`` of the MJCF file at ``path``, what a vehicle's ``load_model`` returns so
    that a world can add obstacles and other vehicles; MulticosimError if it cannot be
    loaded."""
    try:
        return mujoco.MjSpec.from_file(os.fspath(path))
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
    wind also describes its body ([`Bodied`][multicosim.physics.world.Bodied]).
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


VehicleEntry = Any
"""A fleet's vehicle: a [`Vehicle`][multicosim.physics.world.Vehicle], or ``(vehicle, Pose)`` to say
where it starts."""


@dataclasses.dataclass
class _Member:
    """One vehicle of the world: its name ("" alone), start, topics and surroundings."""

    name: str
    vehicle: Vehicle
    pose: Pose | None
    topics: dict[str, str]
    surroundings: Surroundings | None = None
    physics: Physics | None = None
    ctx: StepContext | None = None


class World:
    """A participant that steps MuJoCo in lockstep with the simulation's clock.

    At each period it applies the commands received so far, integrates from the previous
    exchange up to now in one batch, and publishes the sensors for the new state, so the
    readings a controller gets at time ``t`` describe the world at ``t``.

    ``vehicle`` is one vehicle, or a mapping of named vehicles (each a vehicle or a
    ``(vehicle, Pose)``): one model then holds them all, each under its name (its objects
    ``alpha/...``, its topics ``alpha/...``, see [`fleet`][multicosim.fleet]); the wind acts on
    every body and the obstacles stand for all. ``WorldConfig.sensor_topics`` moves a fleet
    vehicle's topic by ``"alpha/gps"``.
    """

    def __init__(self, config: WorldConfig, vehicle: Vehicle | Mapping[str, VehicleEntry]) -> None:
        self.config = config
        self.period = config.period
        self.physics: Physics | None = None
        self._start: float | None = None
        self._contacts: _Contacts | None = None
        if isinstance(vehicle, Mapping):
            member_names(vehicle)
            self.members = [self._member(name, entry) for name, entry in vehicle.items()]
            known = {f"{m.name}/{s}" for m in self.members for s in m.vehicle.sensors}
            check_sensor_topics(config, dict.fromkeys(known, ""))
        else:
            check_sensor_topics(config, vehicle.sensors)
            topics = {name: config.topic(name, t) for name, t in vehicle.sensors.items()}
            self.members = [_Member("", vehicle, None, topics)]
        self.vehicle = self.members[0].vehicle
        """The vehicle (the first of a fleet)."""
        if config.obstacles or config.wind is not None:
            from ._surroundings import Surroundings

            for member in self.members:
                body = member.vehicle
                if not isinstance(body, Bodied):
                    field = "obstacles" if config.obstacles else "wind"
                    raise ConfigurationError(
                        field,
                        getattr(config, field),
                        f"none for a vehicle that does not describe its body ({body!r} has "
                        "no `body`: see physics.Bodied)",
                    )
                member.surroundings = Surroundings(config, body.body, member.name)

    def _member(self, name: str, entry: VehicleEntry) -> _Member:
        check_name(name)
        vehicle, pose = entry if isinstance(entry, tuple) else (entry, Pose())
        if not isinstance(pose, Pose):
            raise ConfigurationError(f"vehicles[{name!r}]", entry, "a vehicle or (vehicle, Pose)")
        topics = {
            s: self.config.topic(f"{name}/{s}", fleet_topic(name, t))
            for s, t in vehicle.sensors.items()
        }
        return _Member(name, vehicle, pose, topics)

    @property
    def fleet(self) -> bool:
        """Whether the world holds named vehicles (a mapping was given)."""
        return self.members[0].pose is not None

    @property
    def topics(self) -> dict[str, str]:
        """The topic of each sensor, after remapping (a fleet's as ``alpha/gps``)."""
        if not self.fleet:
            return dict(self.members[0].topics)
        return {f"{m.name}/{s}": t for m in self.members for s, t in m.topics.items()}

    def setup(self, ctx: StepContext) -> None:
        """Load the model(s), let each vehicle subscribe (and set its initial state)."""
        if self.fleet:
            from ._assembly import assemble

            bodies = {
                m.name: m.vehicle.body if isinstance(m.vehicle, Bodied) else None
                for m in self.members
            }
            model, views = assemble(self.config, self.members, bodies)
            self.physics = physics = Physics(model, self.config)
            self._contacts = _Contacts(model, [m.name for m in self.members])
            for member, slices in zip(self.members, views, strict=True):
                member.physics = MemberPhysics(physics, f"{member.name}/", *slices)
                member.ctx = cast("StepContext", _MemberContext(ctx, member.name))
        else:
            member = self.members[0]
            spec = member.vehicle.load_model()
            if isinstance(spec, mujoco.MjSpec):
                if member.surroundings is not None:
                    member.surroundings.attach(spec)
                    member.surroundings.attach_sphere(spec)
                model = spec.compile()
            else:
                model = spec
                if member.surroundings is not None and member.surroundings.placed:
                    raise ConfigurationError(
                        "obstacles",
                        self.config.obstacles,
                        "none for a vehicle whose load_model() returns a compiled MjModel "
                        "(return an MjSpec so the world can add them)",
                    )
            self.physics = physics = Physics(model, self.config)
            member.physics, member.ctx = physics, ctx
        for member in self.members:
            if member.surroundings is not None:
                member.surroundings.bind(physics.model, ctx.seed, self.period)
        for member in self.members:
            assert member.physics is not None
            assert member.ctx is not None
            member.vehicle.setup(member.physics, member.ctx, member.topics)
        # The first readings are published before any step: they must describe the state
        # the vehicles may have just set.
        physics.forward()
        self._measure(ctx.time)

    def _measure(self, time: float) -> None:
        physics = self.physics
        assert physics is not None
        for member in self.members:
            if member.surroundings is not None and member.physics is not None:
                member.physics.proximity = member.surroundings.measure(
                    physics.model, physics.data, time
                )

    def step(self, ctx: StepContext) -> None:
        """Apply commands, integrate up to ``ctx.time``, publish sensors."""
        physics = self.physics
        assert physics is not None, "setup() was not called"
        if self._start is None:
            # The world may join a simulation whose clock already runs: its physics time
            # starts at zero when it is first stepped.
            self._start = ctx.time
        members = self.members
        for member in members:
            member.vehicle.actuate(member.physics, member.ctx)  # type: ignore[arg-type]
            if member.surroundings is not None:
                member.surroundings.blow(physics.model, physics.data, physics.time)
        physics.step_to(ctx.time - self._start)
        self._measure(ctx.time)
        if self._contacts is not None:
            for contact in self._contacts.new(physics.model, physics.data, ctx.time):
                ctx.publish(CONTACTS_TOPIC, contact)
        for member in members:
            member.vehicle.sense(member.physics, member.ctx)  # type: ignore[arg-type]

    def close(self) -> None:
        """Release the model and state."""
        self.physics = None
        for member in self.members:
            member.physics = None


class _Contacts:
    """The contacts between a fleet's vehicles (their contact spheres), as they begin."""

    def __init__(self, model: Any, names: list[str]) -> None:
        self._geoms: dict[int, tuple[str, int]] = {}
        for name in names:
            geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"{name}/{CONTACT_GEOM}")
            if geom >= 0:
                self._geoms[geom] = (name, int(model.geom_bodyid[geom]))
        self._order = {name: i for i, name in enumerate(names)}
        self._touching: set[tuple[str, str]] = set()
        self._velocity = np.zeros(6)

    def _speed(self, model: Any, data: Any, body: int) -> list[float]:
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, self._velocity, 0)
        return self._velocity[3:].tolist()  # type: ignore[no-any-return]

    def new(self, model: Any, data: Any, time: float) -> list[VehicleContact]:
        """The contacts that began since the last call."""
        if len(self._geoms) < 2:
            return []
        geoms = self._geoms
        now: dict[tuple[str, str], tuple[int, int]] = {}
        for g1, g2 in data.contact.geom[: data.ncon].tolist():
            if g1 in geoms and g2 in geoms:
                (a, body_a), (b, body_b) = geoms[g1], geoms[g2]
                if self._order[a] > self._order[b]:
                    (a, body_a), (b, body_b) = (b, body_b), (a, body_a)
                now[(a, b)] = (body_a, body_b)
        found = []
        for (a, b), (body_a, body_b) in now.items():
            if (a, b) not in self._touching:
                va, vb = self._speed(model, data, body_a), self._speed(model, data, body_b)
                speed = math.dist(va, vb)
                found.append(VehicleContact(a, b, time, speed))
        self._touching = set(now)
        return found


class _MemberContext:
    """A fleet vehicle's view of the world's step context: the world's clock and topics, a
    random generator of its own (so its noise does not depend on the others')."""

    def __init__(self, ctx: StepContext, name: str) -> None:
        from ..runtime.context import derive_seed

        self._ctx = ctx
        self.name = f"{ctx.name}/{name}"
        self.seed = derive_seed(ctx.seed, name)
        self._rng: Any = None

    @property
    def time(self) -> float:
        """Current simulated time in seconds."""
        return self._ctx.time

    @property
    def time_ns(self) -> int:
        """Current simulated time in nanoseconds."""
        return self._ctx.time_ns

    @property
    def rng(self) -> Any:
        """A NumPy generator seeded from the world's seed and the vehicle's name."""
        if self._rng is None:
            import numpy as np

            self._rng = np.random.default_rng(self.seed)
        return self._rng

    def publish(self, topic: str, msg: object) -> None:
        """Publish ``msg`` on ``topic`` (the world's)."""
        self._ctx.publish(topic, msg)

    def subscribe(self, topic: str, tp: Any) -> Any:
        """Receive ``topic`` (through the world)."""
        return self._ctx.subscribe(topic, tp)
