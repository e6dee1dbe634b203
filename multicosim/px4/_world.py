"""The physics world of the PX4 scenario: a participant publishing HIL sensors.

Two vehicle models behind one interface (``QuadrotorWorld``):

* ``point_mass`` (low fidelity): a point mass whose velocity follows the autopilot's velocity
  setpoint with a first-order lag, ideal sensors; scalar math so a minute of flight costs
  milliseconds;
* ``mujoco`` (medium): the MJCF X-quadrotor (``models/quadrotor.xml``) stepped with MuJoCo,
  driven by the four motor outputs, with noisy sensors.

Both read HIL_ACTUATOR_CONTROLS from ``topics.actuators`` and publish HIL_SENSOR (IMU,
magnetometer, barometer on their own topics) and HIL_GPS, plus the ground truth.
"""

from __future__ import annotations

import math
from importlib import resources
from typing import Any, Literal

import msgspec

from .._errors import ConfigurationError
from .._runtime import StepContext, Subscription
from ._config import MuJoCo
from ._geo import LocalProjection, pressure_hpa
from ._hil import (
    ACTUATOR_FLAG_VELOCITY,
    ARMED_FLAG,
    BARO_FIELDS,
    IMU_FIELDS,
    MAG_FIELDS,
    HilActuatorControls,
    HilGps,
    HilSensor,
    MavlinkPacket,
    Truth,
    Wire,
    pack,
    read,
)

__all__ = ["QuadrotorWorld", "WorldSpec", "model_path", "world"]

GRAVITY = 9.80665
MAG_NED = (0.21, 0.015, 0.43)  # gauss, about Zurich (declination ~4 deg, inclination ~63 deg)
GPS_PERIOD = 0.1
MAG_BARO_PERIOD = 0.02
TRUTH_PERIOD = 0.05

Model = Literal["point_mass", "mujoco"]


def model_path() -> str:
    """Path of the packaged MJCF quadrotor."""
    return str(resources.files("multicosim.px4").joinpath("models/quadrotor.xml"))


_ZERO3 = (0.0, 0.0, 0.0)
_NO_BARO = (0.0, 0.0, 0.0, 0.0)


def _hil_sensor(
    t_us: int,
    fields: int,
    motion: tuple[float, ...] = _ZERO3 + _ZERO3,
    mag: tuple[float, ...] = _ZERO3,
    baro: tuple[float, ...] = _NO_BARO,
) -> HilSensor:
    """A HIL_SENSOR from its parts: accel + gyro, magnetometer, (pressure, diff, alt, temp)."""
    m, b = motion, baro
    return HilSensor(
        t_us, m[0], m[1], m[2], m[3], m[4], m[5], mag[0], mag[1], mag[2], b[0], b[1], b[2], b[3],
        fields,
    )  # fmt: skip


class WorldSpec(msgspec.Struct, frozen=True, kw_only=True):
    """Everything the world participant needs (JSON-encodable, for a world process)."""

    model: Model = "mujoco"
    world: MuJoCo = msgspec.field(default_factory=MuJoCo)
    wire: Wire = "native"
    point_mass_period: float = 0.02
    velocity_tau: float = 0.35

    def __post_init__(self) -> None:
        if self.model not in ("point_mass", "mujoco"):
            raise ConfigurationError("model", self.model, "'point_mass' or 'mujoco'")
        if self.wire not in ("native", "mavlink"):
            raise ConfigurationError("wire", self.wire, "'native' or 'mavlink'")

    @property
    def period(self) -> float:
        """Simulated seconds between two world steps (and IMU samples)."""
        return self.point_mass_period if self.model == "point_mass" else self.world.period


def _every(period: float, base: float) -> int:
    return max(1, round(period / base))


class _PointMass:
    """Velocity-tracking point mass (north, east, down) with yaw; ground at down = 0."""

    def __init__(self, dt: float, tau: float) -> None:
        self.dt = dt
        self.alpha = 1.0 - math.exp(-dt / tau)
        self.pos = [0.0, 0.0, 0.0]
        self.vel = [0.0, 0.0, 0.0]
        self.acc = [0.0, 0.0, 0.0]
        self.yaw = 0.0
        self.yaw_rate = 0.0

    def step(self, cmd: HilActuatorControls | None) -> None:
        dt, vel, pos = self.dt, self.vel, self.pos
        on_ground = pos[2] >= -1e-6
        if cmd is not None and cmd.mode & ARMED_FLAG and cmd.flags & ACTUATOR_FLAG_VELOCITY:
            c = cmd.controls
            sp = (c[0], c[1], c[2])
            yaw_err = (c[3] - self.yaw + math.pi) % (2 * math.pi) - math.pi
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
        pos[0] += vel[0] * dt
        pos[1] += vel[1] * dt
        pos[2] += vel[2] * dt
        if pos[2] > 0.0:  # below ground: the ground stops it
            pos[2] = 0.0
            vel[2] = min(vel[2], 0.0)
        if pos[2] >= -1e-6 and sp[2] >= -1e-3:
            vel[0] = vel[1] = 0.0  # friction: no sliding on the ground
        self.acc = [(vel[i] - old[i]) / dt for i in range(3)]
        self.yaw = (self.yaw + self.yaw_rate * dt + math.pi) % (2 * math.pi) - math.pi

    def imu(self) -> tuple[float, ...]:
        """Specific force and angular rate in FRD, magnetic field in FRD (level attitude)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        fn, fe, fd = self.acc[0], self.acc[1], self.acc[2] - GRAVITY
        mn, me, md = MAG_NED
        return (
            c * fn + s * fe,
            -s * fn + c * fe,
            fd,
            0.0,
            0.0,
            self.yaw_rate,
            c * mn + s * me,
            -s * mn + c * me,
            md,
        )


class _MuJoCoQuad:
    """The MJCF quadrotor; positions converted from MuJoCo's north-west-up to NED."""

    def __init__(self, config: MuJoCo) -> None:
        try:
            import mujoco
        except ImportError as exc:  # pragma: no cover - depends on the installation
            from .._errors import DependencyMissingError

            raise DependencyMissingError("mujoco", "mujoco") from exc
        self._mujoco = mujoco
        model = mujoco.MjModel.from_xml_path(model_path())
        model.opt.timestep = config.timestep
        model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{config.integrator.upper()}")
        model.opt.solver = getattr(mujoco.mjtSolver, f"mjSOL_{config.solver.upper()}")
        model.opt.iterations = config.iterations
        self.model = model
        self.data = mujoco.MjData(model)
        self.substeps = config.substeps
        mujoco.mj_forward(model, self.data)

    def step(self, cmd: HilActuatorControls | None) -> None:
        d = self.data
        if cmd is not None and cmd.mode & ARMED_FLAG and not cmd.flags & ACTUATOR_FLAG_VELOCITY:
            c = cmd.controls
            d.ctrl[:] = (c[0], c[1], c[2], c[3])
        else:
            d.ctrl[:] = 0.0
        self._mujoco.mj_step(self.model, d, nstep=self.substeps)

    def state(self) -> tuple[list[float], list[float], list[float]]:
        """qpos, qvel and sensordata as lists (one conversion each per step)."""
        d = self.data
        return d.qpos.tolist(), d.qvel.tolist(), d.sensordata.tolist()


class QuadrotorWorld:
    """The world participant: steps the vehicle model, publishes sensors and truth."""

    def __init__(self, spec: WorldSpec | None = None) -> None:
        self.spec = spec = spec or WorldSpec()
        self.period = spec.period
        self.topics = spec.world.topics
        home = spec.world.home
        self.home = home
        self.proj = LocalProjection(home.lat, home.lon)
        self._noise = 0.0 if spec.model == "point_mass" else spec.world.noise
        self._gps_every = _every(GPS_PERIOD, self.period)
        self._slow_every = _every(MAG_BARO_PERIOD, self.period)
        self._truth_every = _every(TRUTH_PERIOD, self.period)
        self._n = 0
        self._randn: list[float] = []
        self._ri = 0
        self._point: _PointMass | None = None
        self._quad: _MuJoCoQuad | None = None
        if spec.model == "point_mass":
            self._point = _PointMass(self.period, spec.velocity_tau)
        else:
            self._quad = _MuJoCoQuad(spec.world)
        self._rng: Any = None
        self._actuators: Subscription[Any] | None = None
        self._last_cmd: HilActuatorControls | None = None
        self._mavlink = spec.wire == "mavlink"
        # Truth in NED and its velocity (updated every step).
        self.ned = (0.0, 0.0, 0.0)
        self.vel = (0.0, 0.0, 0.0)

    # -- participant ------------------------------------------------------------------------

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the actuator outputs."""
        tp = MavlinkPacket if self._mavlink else HilActuatorControls
        self._actuators = ctx.subscribe(self.topics.actuators, tp)
        self._rng = ctx.rng if self._noise > 0 else None

    def _gauss(self, sigma: float) -> float:
        if sigma == 0.0:
            return 0.0
        if self._ri >= len(self._randn):
            # Draw in blocks: one NumPy call per few thousand samples keeps the loop cheap.
            self._randn = self._rng.standard_normal(4096).tolist()
            self._ri = 0
        self._ri += 1
        return self._randn[self._ri - 1] * sigma

    def step(self, ctx: StepContext) -> None:
        """Apply the latest actuator outputs, advance one period, publish what is due."""
        sub = self._actuators
        assert sub is not None
        if sub._deliveries:
            latest = sub.latest
            self._last_cmd = read(latest, HilActuatorControls) if self._mavlink else latest
        cmd = self._last_cmd
        if self._point is not None:
            p = self._point
            p.step(cmd)
            imu = p.imu()
            self.ned = (p.pos[0], p.pos[1], p.pos[2])
            self.vel = (p.vel[0], p.vel[1], p.vel[2])
        else:
            q = self._quad
            assert q is not None
            q.step(cmd)
            qpos, qvel, s = q.state()
            self.ned = (qpos[0], -qpos[1], -(qpos[2] - 0.12))
            self.vel = (qvel[0], -qvel[1], -qvel[2])
            # MuJoCo's sensors are in the body's FLU frame; PX4 wants FRD.
            imu = (s[0], -s[1], -s[2], s[3], -s[4], -s[5], s[6], -s[7], -s[8])
        self._publish(ctx, imu)

    # -- sensors ----------------------------------------------------------------------------

    def _publish(self, ctx: StepContext, imu: tuple[float, ...]) -> None:
        n = self._n
        self._n = n + 1
        t_us = ctx.time_ns // 1000
        k = self._noise
        g = self._gauss
        topics = self.topics
        alt_msl = self.home.alt - self.ned[2]
        slow = n % self._slow_every == 0
        temp = 15.0 - 0.0065 * alt_msl
        if k:
            acc_s, gyr_s = 0.02 * k, 0.002 * k
            motion: tuple[float, ...] = (
                imu[0] + g(acc_s),
                imu[1] + g(acc_s),
                imu[2] + g(acc_s),
                imu[3] + g(gyr_s),
                imu[4] + g(gyr_s),
                imu[5] + g(gyr_s),
            )
        else:
            motion = imu[:6]
        if not slow:
            self._emit(ctx, topics.imu, _hil_sensor(t_us, IMU_FIELDS, motion=motion))
        else:
            # Drawn in one order whichever topics the readings go to, so that remapping a
            # sensor (to put an injector in front of it) leaves the noise unchanged.
            mag_s = 0.003 * k
            mag = (imu[6] + g(mag_s), imu[7] + g(mag_s), imu[8] + g(mag_s))
            baro_alt = alt_msl + g(0.1 * k)
            baro = (pressure_hpa(baro_alt), 0.0, baro_alt, temp)
            if topics.mag == topics.imu == topics.baro:
                # One combined HIL_SENSOR where the topics coincide, as PX4 SITL receives it.
                fields = IMU_FIELDS | MAG_FIELDS | BARO_FIELDS
                self._emit(ctx, topics.imu, _hil_sensor(t_us, fields, motion, mag, baro))
            else:
                self._emit(ctx, topics.imu, _hil_sensor(t_us, IMU_FIELDS, motion=motion))
                self._emit(ctx, topics.mag, _hil_sensor(t_us, MAG_FIELDS, mag=mag))
                self._emit(ctx, topics.baro, _hil_sensor(t_us, BARO_FIELDS, baro=baro))
        if n % self._gps_every == 0:
            self._emit(ctx, topics.gps, self._gps(t_us, alt_msl))
        if n % self._truth_every == 0:
            lat, lon = self.proj.reproject(self.ned[0], self.ned[1])
            ctx.publish(
                topics.truth,
                Truth(
                    ctx.time,
                    self.ned[0],
                    self.ned[1],
                    self.ned[2],
                    self.vel[0],
                    self.vel[1],
                    self.vel[2],
                    lat,
                    lon,
                    -self.ned[2],
                ),
            )

    def _gps(self, t_us: int, alt_msl: float) -> HilGps:
        k = self._noise
        g = self._gauss
        n, e, _ = self.ned
        lat, lon = self.proj.reproject(n + g(0.15 * k), e + g(0.15 * k))
        vn, ve, vd = (v + g(0.03 * k) for v in self.vel)
        alt = alt_msl + g(0.3 * k)
        speed = math.hypot(vn, ve)
        cog = math.degrees(math.atan2(ve, vn)) % 360.0
        return HilGps(
            t_us,
            3,
            round(lat * 1e7),
            round(lon * 1e7),
            round(alt * 1000),
            70,
            100,
            round(speed * 100),
            round(vn * 100),
            round(ve * 100),
            round(vd * 100),
            round(cog * 100) % 36000,
            12,
        )

    def _emit(self, ctx: StepContext, topic: str, msg: HilSensor | HilGps) -> None:
        ctx.publish(topic, pack(msg) if self._mavlink else msg)

    def close(self) -> None:
        """Release the physics state."""
        self._quad = None


def world(spec: WorldSpec) -> QuadrotorWorld:
    """Factory for ``multicosim participant multicosim.px4._world:world --config JSON``."""
    return QuadrotorWorld(spec)
