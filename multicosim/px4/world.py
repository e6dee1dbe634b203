"""The physics world of the PX4 scenario: a participant publishing PX4's sensor messages.

Two vehicle models, the same sensor messages (``HilSensors``):

* ``point_mass`` (low fidelity): a point mass whose velocity follows the autopilot's velocity
  setpoint with a first-order lag, ideal sensors; scalar math so a minute of flight costs
  milliseconds;
* ``mujoco`` (medium and up, and what real PX4 flies): the shared MuJoCo world
  ([`multicosim.physics.World`][multicosim.physics.World]) with the quadrotor vehicle built from
  PX4's ``none_iris`` airframe, driven by the four motor outputs, with noisy sensors.

Both read HIL_ACTUATOR_CONTROLS from the actuator topic and publish HIL_SENSOR, HIL_GPS and
the ground truth.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import msgspec

from ..core.errors import ConfigurationError
from ..core.geo import GRAVITY
from ..mavlink.dialect import MODE_FLAG_ARMED
from ..mavlink.hil import ACTUATOR_FLAG_VELOCITY, HilActuatorControls, MavlinkPacket, Wire, read
from ..physics.config import WorldConfig
from ..physics.fleet import Pose, resolve_pose
from ..physics.obstacles import ClearanceMonitor, placed
from ..physics.wind import Body, WindField, drag_force, wind_generator
from ..quadrotor.airframe import NONE_IRIS
from ..quadrotor.sensors import HilSensors
from ..runtime.context import StepContext, Subscription

__all__ = ["PointMassWorld", "WorldSpec", "world"]


Model = Literal["point_mass", "mujoco"]


class WorldSpec(msgspec.Struct, frozen=True, kw_only=True):
    """Everything the world participant needs (JSON-encodable, for a world process)."""

    model: Model = "mujoco"
    world: WorldConfig = msgspec.field(default_factory=WorldConfig)
    wire: Wire = "native"
    point_mass_period: float = 0.02
    velocity_tau: float = 0.35
    start: Pose | None = None
    """Where the point mass starts (None: at home, facing north); a fleet's vehicle's start."""

    def __post_init__(self) -> None:
        if self.model not in ("point_mass", "mujoco"):
            raise ConfigurationError("model", self.model, "'point_mass' or 'mujoco'")
        if self.wire not in ("native", "mavlink"):
            raise ConfigurationError("wire", self.wire, "'native' or 'mavlink'")

    @property
    def period(self) -> float:
        """Simulated seconds between two world steps (and IMU samples)."""
        return self.point_mass_period if self.model == "point_mass" else self.world.period


REJECTION_TIME = 1.8 / 0.4
"""s: how fast PX4's velocity loop (MPC_XY_VEL_P_ACC over MPC_XY_VEL_I_ACC) takes up a steady
disturbance; the point mass rejects its wind's drag so."""


class PointMassWorld:
    """Velocity-tracking point mass (north, east, down) with yaw; ground at down = 0.

    The low-fidelity world: the autopilot sends its velocity setpoint in
    HIL_ACTUATOR_CONTROLS (flagged by ``ACTUATOR_FLAG_VELOCITY``) and the point mass follows
    it with a first-order lag, standing in for the attitude and rate loops. Sensors are ideal.
    The world's obstacles are measured analytically (a collision is the body's sphere
    touching one) and its wind pushes the mass through the airframe's drag.
    """

    def __init__(self, spec: WorldSpec) -> None:
        self.spec = spec
        self.period = dt = spec.period
        self.alpha = 1.0 - math.exp(-dt / spec.velocity_tau)
        self.pos = [0.0, 0.0, 0.0]
        self.vel = [0.0, 0.0, 0.0]
        self.yaw = 0.0
        if spec.start is not None:
            north, east, up, yaw = resolve_pose(spec.start, spec.world.home)
            self.pos = [north, east, -up]
            self.yaw = 0.0 if yaw is None else math.radians(yaw)
        self.yaw_rate = 0.0
        self._hil = HilSensors(spec.world, dt, spec.wire, ideal=True)
        self._actuators: Subscription[Any] | None = None
        self._cmd: HilActuatorControls | None = None
        self._mavlink = spec.wire == "mavlink"
        airframe = NONE_IRIS
        self.mass = airframe.mass
        self.body = Body("vehicle", airframe.radius, airframe.drag_coefficient, airframe.drag_area)
        self._monitor = ClearanceMonitor(
            placed(spec.world.obstacles, spec.world.home), self.body.radius
        )
        self._wind: WindField | None = None
        self._time = 0.0
        self.air = (0.0, 0.0, 0.0)
        # What the (modelled) velocity controller has learnt to push against the wind, m/s².
        self._against = [0.0, 0.0]
        # The body's centre stands this high when the point mass is on the ground.
        self._height = airframe.ground_offset

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the actuator outputs; seed the wind."""
        if self.spec.world.wind is not None:
            self._wind = WindField(self.spec.world.wind, self.period, wind_generator(ctx.seed))
        tp = MavlinkPacket if self._mavlink else HilActuatorControls
        self._actuators = ctx.subscribe(self._hil.topics.actuators, tp)
        self._hil.setup(ctx)

    def step(self, ctx: StepContext) -> None:
        """Apply the latest velocity setpoint, advance one period, publish the sensors."""
        sub = self._actuators
        assert sub is not None
        if sub.fresh:
            latest = sub.latest
            self._cmd = read(latest, HilActuatorControls) if self._mavlink else latest
        acc = self._advance(self._cmd)
        pos, vel = self.pos, self.vel
        proximity = self._monitor.update(
            ctx.time,
            pos[0],
            pos[1],
            self._height - pos[2],
            math.sqrt(vel[0] ** 2 + vel[1] ** 2 + vel[2] ** 2),
        )
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        # Level attitude: only yaw turns the body; specific force is acceleration minus gravity.
        fn, fe, fd = acc[0], acc[1], acc[2] - GRAVITY
        half = 0.5 * self.yaw
        self._hil.publish(
            ctx,
            (self.pos[0], self.pos[1], self.pos[2]),
            (self.vel[0], self.vel[1], self.vel[2]),
            (math.cos(half), 0.0, 0.0, math.sin(half)),
            (c * fn + s * fe, -s * fn + c * fe, fd),
            (0.0, 0.0, self.yaw_rate),
            proximity=proximity,
        )

    def _advance(self, cmd: HilActuatorControls | None) -> tuple[float, float, float]:
        dt, vel, pos = self.period, self.vel, self.pos
        on_ground = pos[2] >= -1e-6
        if cmd is not None and cmd.mode & MODE_FLAG_ARMED and cmd.flags & ACTUATOR_FLAG_VELOCITY:
            ctl = cmd.controls
            sp = (ctl[0], ctl[1], ctl[2])
            yaw_err = (ctl[3] - self.yaw + math.pi) % (2 * math.pi) - math.pi
            self.yaw_rate = max(-1.5, min(1.5, yaw_err / 0.3))
        else:
            # Unpowered: it falls (and stays on the ground).
            sp = (0.0, 0.0, 20.0) if not on_ground else (0.0, 0.0, 0.0)
            self.yaw_rate = 0.0
        old = (vel[0], vel[1], vel[2])
        a = self.alpha
        vel[0] += a * (sp[0] - vel[0])
        vel[1] += a * (sp[1] - vel[1])
        vel[2] += a * (sp[2] - vel[2])
        wind = self._wind
        if wind is not None:
            north, east, up = self.air = wind.step(self._time, -pos[2])
            force = drag_force(self.body, (north, east, -up), (vel[0], vel[1], vel[2]))
            k = dt / self.mass
            # The lag stands for a controller with integral action (PX4's velocity loop):
            # it learns the horizontal drag with its time constant, P over I gain (1.8 / 0.4
            # s), and pushes back, so a steady wind leaves no lasting velocity error.
            against, learn = self._against, dt / REJECTION_TIME
            if on_ground:
                against[0] = against[1] = 0.0
            else:
                against[0] += (-force[0] / self.mass - against[0]) * learn
                against[1] += (-force[1] / self.mass - against[1]) * learn
            vel[0] += force[0] * k + against[0] * dt
            vel[1] += force[1] * k + against[1] * dt
            if not on_ground:
                vel[2] += force[2] * k
        self._time += dt
        pos[0] += vel[0] * dt
        pos[1] += vel[1] * dt
        pos[2] += vel[2] * dt
        if pos[2] > 0.0:  # below ground: the ground stops it
            pos[2] = 0.0
            vel[2] = min(vel[2], 0.0)
        if pos[2] >= -1e-6 and sp[2] >= -1e-3:
            vel[0] = vel[1] = 0.0  # friction: no sliding on the ground
        self.yaw = (self.yaw + self.yaw_rate * dt + math.pi) % (2 * math.pi) - math.pi
        return ((vel[0] - old[0]) / dt, (vel[1] - old[1]) / dt, (vel[2] - old[2]) / dt)


def world(spec: WorldSpec) -> Any:
    """The world participant for ``spec``: the point mass, or the MuJoCo quadrotor.

    Also the factory of ``multicosim participant multicosim.px4.world:world --config JSON``.
    """
    if spec.model == "point_mass":
        return PointMassWorld(spec)
    from ..physics.world import World
    from ..quadrotor.vehicle import QuadrotorVehicle

    return World(spec.world, QuadrotorVehicle(wire=spec.wire))
