"""The low-fidelity rover world: a kinematic bicycle model with the MuJoCo world's topics.

The rear-axle centre moves along arcs of curvature ``tan(steering) / wheelbase``; speed
follows the commanded speed at the drive's acceleration limit; steering is ideal. Within a
period the arc is integrated exactly (position depends only on the distance driven along a
constant-curvature arc), so the period can be coarse without losing accuracy.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..core.geo import GRAVITY, local_to_geodetic, quaternion_from_euler
from ._messages import (
    COMMAND_TOPIC,
    MAX_STEERING,
    SENSOR_TOPICS,
    Command,
    Imu,
    MagneticField,
    Position,
    WheelSpeed,
)
from ._vehicle import (
    ACCELERATION,
    AXLE_HEIGHT,
    TRACK,
    WHEEL_RADIUS,
    WHEELBASE,
    RoverWorldConfig,
    field_in_body,
)

if TYPE_CHECKING:
    from ..runtime.context import StepContext, Subscription

__all__ = ["KinematicWorld", "kinematic_world"]


class KinematicWorld:
    """A participant simulating the rover as a kinematic bicycle (low fidelity).

    Publishes the same sensor messages on the same topics as the MuJoCo world, with the
    configured noise (none by default); ``x, y, heading, speed`` is the true state.
    """

    def __init__(self, config: RoverWorldConfig | None = None) -> None:
        self.config = config or RoverWorldConfig()
        self.period = self.config.world.period
        self.x = 0.0
        self.y = 0.0
        self.heading = 0.0
        self.speed = 0.0
        self.steering = 0.0
        self._accel = 0.0
        self._last: float | None = None
        self._command: Subscription[Command] | None = None
        world = self.config.world
        self._home = world.home
        # Checked once: the ideal (default) case must cost no noise draws at all.
        self._noise = self.config.sensor_noise
        self._ideal = self._noise.ideal
        self._topics = {name: world.topic(name, t) for name, t in SENSOR_TOPICS.items()}

    def setup(self, ctx: StepContext) -> None:
        """Subscribe to the command topic."""
        self._command = ctx.subscribe(COMMAND_TOPIC, Command)

    def step(self, ctx: StepContext) -> None:
        """Integrate from the previous step to now under the latest command; publish sensors."""
        assert self._command is not None, "setup() was not called"
        now = ctx.time
        dt = 0.0 if self._last is None else now - self._last
        self._last = now
        command = self._command.latest
        target = 0.0
        if command is not None:
            target = command.speed
            self.steering = max(-MAX_STEERING, min(MAX_STEERING, command.steering))
        if dt > 0.0:
            self._advance(dt, target)
        self._publish(ctx)

    def _advance(self, dt: float, target: float) -> None:
        v0 = self.speed
        gap = target - v0
        ramp = min(dt, abs(gap) / ACCELERATION)
        accel = math.copysign(ACCELERATION, gap) if ramp > 0.0 else 0.0
        # Distance along the arc: a ramp at the acceleration limit, then constant speed.
        s = v0 * ramp + 0.5 * accel * ramp * ramp
        v1 = v0 + accel * ramp
        s += v1 * (dt - ramp)
        self.speed = v1
        self._accel = accel if ramp >= dt else 0.0
        curvature = math.tan(self.steering) / WHEELBASE
        h0 = self.heading
        if abs(curvature) < 1e-12:
            self.x += s * math.cos(h0)
            self.y += s * math.sin(h0)
        else:
            h1 = h0 + curvature * s
            self.x += (math.sin(h1) - math.sin(h0)) / curvature
            self.y += (math.cos(h0) - math.cos(h1)) / curvature
        self.heading = math.remainder(h0 + curvature * s, math.tau)

    def _publish(self, ctx: StepContext) -> None:
        t = ctx.time
        topics = self._topics
        curvature = math.tan(self.steering) / WHEELBASE
        v, heading = self.speed, self.heading
        x, y, z = self.x, self.y, AXLE_HEIGHT
        mx, my, mz = field_in_body(self.config.world.magnetic_field, 0.0, 0.0, heading)
        accel = [self._accel, v * v * curvature, GRAVITY]
        gyro = [0.0, 0.0, v * curvature]
        speed = v
        if not self._ideal:
            noise, rng = self._noise, ctx.rng
            dx, dy, dz = rng.normal(0.0, noise.position, 3).tolist()
            x, y, z = x + dx, y + dy, z + dz
            dx, dy, dz = rng.normal(0.0, noise.magnetometer, 3).tolist()
            mx, my, mz = mx + dx, my + dy, mz + dz
            accel = (rng.normal(0.0, noise.accelerometer, 3) + accel).tolist()
            gyro = (rng.normal(0.0, noise.gyro, 3) + gyro).tolist()
            speed += float(rng.normal(0.0, noise.wheel_speed))
        lat, lon, alt = local_to_geodetic(self._home, east=x, north=y, up=z)
        publish = ctx.publish
        publish(
            topics["position"],
            Position(time=t, x=x, y=y, z=z, latitude=lat, longitude=lon, altitude=alt),
        )
        publish(topics["magnetometer"], MagneticField(time=t, x=mx, y=my, z=mz))
        publish(
            topics["imu"],
            Imu(
                time=t,
                acceleration=(accel[0], accel[1], accel[2]),
                angular_velocity=(gyro[0], gyro[1], gyro[2]),
                orientation=quaternion_from_euler(0.0, 0.0, heading),
            ),
        )
        half = TRACK / 2 * curvature
        publish(
            topics["wheel_speed"],
            WheelSpeed(
                time=t,
                speed=speed,
                left=v * (1 - half) / WHEEL_RADIUS,
                right=v * (1 + half) / WHEEL_RADIUS,
            ),
        )


def kinematic_world(config: RoverWorldConfig | None = None) -> KinematicWorld:
    """Factory of the low-fidelity world (for ``multicosim participant``)."""
    return KinematicWorld(config)
