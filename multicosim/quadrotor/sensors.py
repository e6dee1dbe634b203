"""PX4's simulated sensors: what a simulator of PX4 SITL sends it, from the vehicle's state.

Every quadrotor world (the low-fidelity point mass and the MuJoCo quadrotor) hands its true
state to ``HilSensors`` once per period; it publishes what PX4's ``simulator_mavlink``
expects (and our autopilot reads):

* ``HIL_SENSOR`` every period with the IMU (specific force and angular rate, body FRD), and
  the magnetometer (gauss) and barometer (hPa, ISA) at 50 Hz, flagged in ``fields_updated``;
  one combined message where the sensor topics coincide, as PX4 SITL receives it;
* ``HIL_GPS`` at 10 Hz: WGS84 position and NED velocity with PX4's Gazebo GNSS error (a
  bias of millimetres that decorrelates within a quarter second, velocity noise);
* ``Truth`` at 20 Hz: the world's ground truth, attitude and
  specific force included.

Noise is scaled by ``WorldConfig.noise`` (0: ideal sensors) and drawn from the component's
seeded generator in one fixed order, whichever topics the readings go to, so that remapping
a sensor (to put an injector in front of it) leaves the noise unchanged.
"""

from __future__ import annotations

import math
from typing import Any

from ..core.geo import LocalProjection, pressure_hpa, rotate_to_body
from ..mavlink.hil import (
    BARO_FIELDS,
    IMU_FIELDS,
    MAG_FIELDS,
    HilGps,
    HilSensor,
    Packer,
    Wire,
    truth,
)
from ..physics.config import WorldConfig
from ..physics.frames import NedState, Vec3
from ..physics.obstacles import NO_OBSTACLES, Proximity
from ..runtime.context import StepContext
from .topics import Topics, world_topics

__all__ = ["GPS_PERIOD", "HilSensors", "Vec3"]

GPS_PERIOD = 0.1
MAG_BARO_PERIOD = 0.02
TRUTH_PERIOD = 0.05

# Noise as PX4's own simulation makes it (the Gazebo sensor plugins of its gazebo-classic
# models at v1.15: gazebo_gps_plugin, the iris model's gazebo_imu_plugin parameters,
# gazebo_barometer_plugin, gazebo_magnetometer_plugin), so that real PX4 flies our world as it
# flies Gazebo. Gazebo steps these models every physics step of its worlds (4 ms).
GAZEBO_STEP = 0.004  # s
# GNSS: a bias that random-walks (2 and 4 (m/s)/sqrt(Hz) horizontally and vertically) and
# decays by 1/60 of itself each step, plus velocity noise (0.2 and 0.4 (m/s)/sqrt(Hz)), both
# scaled by sqrt(step) as the plugin does: millimetres of position error, no slow drift.
_GPS_RANDOM_WALK = (2.0, 2.0, 4.0)
_GPS_DECAY_STEPS = 60.0
GPS_DRIFT_TIME = _GPS_DECAY_STEPS * GAZEBO_STEP  # s, correlation time of the bias
GPS_DRIFT_SIGMA = tuple(
    w * GAZEBO_STEP**1.5 / math.sqrt(1.0 - (1.0 - 1.0 / _GPS_DECAY_STEPS) ** 2)
    for w in _GPS_RANDOM_WALK
)  # m (north, east, down) at noise 1: the bias's stationary spread
GPS_VEL_SIGMA = (0.2 * math.sqrt(GAZEBO_STEP),) * 2 + (0.4 * math.sqrt(GAZEBO_STEP),)  # m/s
GPS_EPH_CM, GPS_EPV_CM = 100, 100  # reported accuracy (the plugin's std_xy, std_z: 1 m)
# IMU white noise densities (iris: gyroscope 0.00018665 rad/s/sqrt(Hz), accelerometer
# 0.00186 m/s^2/sqrt(Hz)), magnetometer 0.0004 gauss/sqrt(Hz): per sample, density/sqrt(dt).
ACCEL_DENSITY, GYRO_DENSITY, MAG_DENSITY = 0.00186, 0.00018665, 0.0004
# Barometer: 1 Pa RMS, no drift; as altitude near the ground (1 / (rho g)).
BARO_SIGMA = 1.0 / (1.225 * 9.80665)  # m

_ZERO3: Vec3 = (0.0, 0.0, 0.0)
_NO_BARO = (0.0, 0.0, 0.0, 0.0)


def _hil_sensor(
    t_us: int,
    fields: int,
    motion: tuple[float, ...] = _ZERO3 + _ZERO3,
    mag: Vec3 = _ZERO3,
    baro: tuple[float, float, float, float] = _NO_BARO,
) -> HilSensor:
    """A HIL_SENSOR from its parts: accel + gyro, magnetometer, (pressure, diff, alt, temp)."""
    m, b = motion, baro
    return HilSensor(
        t_us, m[0], m[1], m[2], m[3], m[4], m[5], mag[0], mag[1], mag[2], b[0], b[1], b[2], b[3],
        fields,
    )  # fmt: skip


def _every(period: float, base: float) -> int:
    return max(1, round(period / base))


class HilSensors:
    """Turns a vehicle's true state into PX4's sensor messages on the world's topics."""

    def __init__(
        self,
        world: WorldConfig,
        period: float,
        wire: Wire,
        *,
        ideal: bool = False,
        topics: Topics | None = None,
    ) -> None:
        self.world = world
        self.topics: Topics = topics or world_topics(world)
        self.home = world.home
        self.proj = LocalProjection.at(world.home)
        self._noise = 0.0 if ideal else world.noise
        self._mavlink = wire == "mavlink"
        self._packer = Packer()
        east, north, up = world.magnetic_field
        # Earth's field in NED gauss (the configuration is ENU tesla).
        self._field: Vec3 = (north * 1e4, east * 1e4, -up * 1e4)
        self._gps_every = _every(GPS_PERIOD, period)
        self._imu_sigma = (ACCEL_DENSITY / math.sqrt(period), GYRO_DENSITY / math.sqrt(period))
        self._mag_sigma = MAG_DENSITY / math.sqrt(MAG_BARO_PERIOD)
        self._slow_every = _every(MAG_BARO_PERIOD, period)
        self._truth_every = _every(TRUTH_PERIOD, period)
        self._combined = self.topics.mag == self.topics.imu == self.topics.baro
        decay = math.exp(-GPS_PERIOD / GPS_DRIFT_TIME)
        self._drift_decay = decay
        self._drift_kick = math.sqrt(1.0 - decay * decay)
        self._drift: list[float] | None = None
        self._n = 0
        self._rng: Any = None
        self._randn: list[float] = []
        self._ri = 0

    def setup(self, ctx: StepContext) -> None:
        """Take the component's seeded generator (only drawn from when noisy)."""
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

    def publish(
        self,
        ctx: StepContext,
        ned: Vec3,
        vel: Vec3,
        q: tuple[float, float, float, float],
        accel: Vec3,
        gyro: Vec3,
        *,
        proximity: Proximity = NO_OBSTACLES,
    ) -> None:
        """Publish what is due at ``ctx.time`` for the true state given.

        ``ned``/``vel``: position (m, from home) and velocity (m/s) in NED; ``q``: attitude
        (w, x, y, z, FRD body to NED); ``accel``: specific force and ``gyro``: angular rate,
        both in the body frame; ``proximity``: the vehicle's clearances, for the truth.
        """
        n = self._n
        self._n = n + 1
        t_us = ctx.time_ns // 1000
        k = self._noise
        g = self._gauss
        topics = self.topics
        alt_msl = self.home.alt - ned[2]
        if k:
            acc_s, gyr_s = self._imu_sigma[0] * k, self._imu_sigma[1] * k
            motion: tuple[float, ...] = (
                accel[0] + g(acc_s),
                accel[1] + g(acc_s),
                accel[2] + g(acc_s),
                gyro[0] + g(gyr_s),
                gyro[1] + g(gyr_s),
                gyro[2] + g(gyr_s),
            )
        else:
            motion = (*accel, *gyro)
        if n % self._slow_every:
            self._emit(ctx, topics.imu, _hil_sensor(t_us, IMU_FIELDS, motion))
        else:
            bx, by, bz = rotate_to_body(q, self._field)
            mag_s = self._mag_sigma * k
            mag = (bx + g(mag_s), by + g(mag_s), bz + g(mag_s))
            baro_alt = alt_msl + g(BARO_SIGMA * k)
            baro = (pressure_hpa(baro_alt), 0.0, baro_alt, 15.0 - 0.0065 * alt_msl)
            if self._combined:
                fields = IMU_FIELDS | MAG_FIELDS | BARO_FIELDS
                self._emit(ctx, topics.imu, _hil_sensor(t_us, fields, motion, mag, baro))
            else:
                self._emit(ctx, topics.imu, _hil_sensor(t_us, IMU_FIELDS, motion))
                self._emit(ctx, topics.mag, _hil_sensor(t_us, MAG_FIELDS, mag=mag))
                self._emit(ctx, topics.baro, _hil_sensor(t_us, BARO_FIELDS, baro=baro))
        if n % self._gps_every == 0:
            self._emit(ctx, topics.gps, self._gps(t_us, ned, vel, alt_msl))
        if n % self._truth_every == 0:
            state = NedState(ned, vel, q, accel, gyro)
            ctx.publish(topics.truth, truth(ctx.time, state, self.proj, proximity))

    def _gps(self, t_us: int, ned: Vec3, vel: Vec3, alt_msl: float) -> HilGps:
        k = self._noise
        g = self._gauss
        drift = self._drift
        if drift is None:
            drift = self._drift = [g(s * k) for s in GPS_DRIFT_SIGMA]
        else:
            a, b = self._drift_decay, self._drift_kick
            for i, s in enumerate(GPS_DRIFT_SIGMA):
                drift[i] = a * drift[i] + b * g(s * k)
        lat, lon = self.proj.reproject(ned[0] + drift[0], ned[1] + drift[1])
        vxy, vz = GPS_VEL_SIGMA[0] * k, GPS_VEL_SIGMA[2] * k
        vn, ve, vd = vel[0] + g(vxy), vel[1] + g(vxy), vel[2] + g(vz)
        speed = math.hypot(vn, ve)
        cog = math.degrees(math.atan2(ve, vn)) % 360.0
        return HilGps(
            t_us,
            3,
            round(lat * 1e7),
            round(lon * 1e7),
            round((alt_msl - drift[2]) * 1000),
            GPS_EPH_CM,
            GPS_EPV_CM,
            round(speed * 100),
            round(vn * 100),
            round(ve * 100),
            round(vd * 100),
            round(cog * 100) % 36000,
            12,
        )

    def _emit(self, ctx: StepContext, topic: str, msg: HilSensor | HilGps) -> None:
        ctx.publish(topic, self._packer.pack(msg) if self._mavlink else msg)
