"""The rover in MuJoCo: the vehicle plug-in of the world and its component factory.

``python -m multicosim participant multicosim.rover.body:rover_world --config JSON`` runs it as
a process; JSON is a [`multicosim.rover.RoverWorldConfig`][multicosim.rover.RoverWorldConfig].
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..physics.world import Physics, World, load_spec
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
from ._vehicle import WHEEL_RADIUS, RoverWorldConfig, SensorNoise, ackermann

if TYPE_CHECKING:
    from ..runtime.context import StepContext, Subscription

__all__ = ["RoverVehicle", "rover_world"]


class RoverVehicle:
    """The four-wheel Ackermann rover of ``models/rover.xml``.

    Reads [`Command`][multicosim.rover.Command] from ``rover/command`` and publishes position,
    magnetometer, IMU and wheel odometry, with the configured white noise.
    """

    model_path = Path(__file__).parent / "models" / "rover.xml"
    sensors: Mapping[str, str] = {**SENSOR_TOPICS, "command": COMMAND_TOPIC}
    """Its topics by name: the sensors it publishes and the command it reads."""

    def __init__(self, noise: SensorNoise | None = None) -> None:
        self.noise = noise or SensorNoise()
        self._command: Subscription[Command] | None = None
        self._topics: Mapping[str, str] = dict(SENSOR_TOPICS)
        self._ctrl: list[int] = []

    def load_model(self) -> Any:
        """The rover's MJCF model (``models/rover.xml``), as a spec: a world adds obstacles
        and other vehicles to it."""
        return load_spec(self.model_path)

    def setup(self, physics: Physics, ctx: StepContext, topics: Mapping[str, str]) -> None:
        """Find the actuators and subscribe to the command topic."""
        self._topics = topics
        # A vehicle of this body driven otherwise (ArduRover's) reads no rover command.
        command = topics.get("command")
        self._command = ctx.subscribe(command, Command) if command is not None else None
        self._ctrl = [
            physics.actuator(name)
            for name in (
                "steer_front_left",
                "steer_front_right",
                "drive_rear_left",
                "drive_rear_right",
            )
        ]
        # Resolve every sensor now so a model without one fails at setup, not mid-run.
        for name in ("position", "orientation", "accelerometer", "gyro", "magnetometer"):
            physics.sensor(name)
        physics.sensor("wheel_rear_left")
        physics.sensor("wheel_rear_right")

    def actuate(self, physics: Physics, ctx: StepContext) -> None:
        """Turn the latest command into steering angles and rear wheel rates."""
        if self._command is None:
            return
        command = self._command.latest
        if command is None:
            return
        self.drive(physics, command.speed, command.steering)

    def drive(self, physics: Physics, speed: float, steering: float) -> None:
        """Set the wheels for ground ``speed`` (m/s) and bicycle ``steering`` (rad, + left)."""
        steering = max(-MAX_STEERING, min(MAX_STEERING, steering))
        ctrl = physics.data.ctrl
        for index, value in zip(self._ctrl, ackermann(speed, steering), strict=True):
            ctrl[index] = value

    def sense(self, physics: Physics, ctx: StepContext) -> None:
        """Publish every sensor for the current physics state."""
        noise = self.noise
        rng = ctx.rng if not noise.ideal else None
        t = ctx.time
        topics = self._topics

        def noisy(values: list[float], sigma: float) -> list[float]:
            if rng is None or sigma == 0.0:
                return values
            return [
                v + float(e)
                for v, e in zip(values, rng.normal(0.0, sigma, len(values)), strict=True)
            ]

        x, y, z = noisy(physics.sensor("position").tolist(), noise.position)
        lat, lon, alt = physics.geodetic(x, y, z)
        ctx.publish(
            topics["position"],
            Position(time=t, x=x, y=y, z=z, latitude=lat, longitude=lon, altitude=alt),
        )
        mx, my, mz = noisy(physics.sensor("magnetometer").tolist(), noise.magnetometer)
        ctx.publish(topics["magnetometer"], MagneticField(time=t, x=mx, y=my, z=mz))
        ax, ay, az = noisy(physics.sensor("accelerometer").tolist(), noise.accelerometer)
        gx, gy, gz = noisy(physics.sensor("gyro").tolist(), noise.gyro)
        qw, qx, qy, qz = physics.sensor("orientation").tolist()
        ctx.publish(
            topics["imu"],
            Imu(
                time=t,
                acceleration=(ax, ay, az),
                angular_velocity=(gx, gy, gz),
                orientation=(qw, qx, qy, qz),
            ),
        )
        left = float(physics.sensor("wheel_rear_left")[0])
        right = float(physics.sensor("wheel_rear_right")[0])
        (speed,) = noisy([(left + right) / 2 * WHEEL_RADIUS], noise.wheel_speed)
        ctx.publish(topics["wheel_speed"], WheelSpeed(time=t, speed=speed, left=left, right=right))


def rover_world(config: RoverWorldConfig | None = None) -> World:
    """A MuJoCo world with the rover in it (the participant factory of the rover scenario)."""
    config = config or RoverWorldConfig()
    return World(config.world, RoverVehicle(config.sensor_noise))
