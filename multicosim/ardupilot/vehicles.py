"""Our MuJoCo vehicles driven by ArduPilot: the world's vehicle plug-ins for its JSON backend.

Each reads ArduPilot's servo outputs (``ServoOutputs``) through its frame
(``_frames``) and publishes, every physics period, the vehicle's true state as the
world's ``Truth`` (NED position from home, velocity, attitude, body
rates and specific force): what ArduPilot's JSON backend needs, and the truth the ground
station records. ArduPilot synthesises its own sensors (IMU noise, GPS, compass, barometer)
from that state, with its ``SIM_*`` parameters.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from ..core.geo import LocalProjection
from ..mavlink.hil import truth
from ..physics.frames import NedState, ned_state
from ..quadrotor.airframe import NONE_IRIS, Airframe
from ..quadrotor.vehicle import QuadrotorVehicle
from ..rover import AXLE_HEIGHT, MAX_SPEED, MAX_STEERING
from ..rover.body import RoverVehicle
from ._bridge import SERVO_TOPIC, TRUTH_TOPIC, ServoOutputs
from ._frames import check_quad_x, motor_outputs, rover_command

if TYPE_CHECKING:
    from ..physics.world import Physics
    from ..runtime.context import StepContext, Subscription

__all__ = ["ArduCopterVehicle", "ArduRoverVehicle"]


class ArduCopterVehicle(QuadrotorVehicle):
    """The quadrotor (PX4's ``none_iris`` airframe) as ArduCopter's quad X."""

    sensors: Mapping[str, str] = {"truth": TRUTH_TOPIC, "servos": SERVO_TOPIC}

    def __init__(self, airframe: Airframe = NONE_IRIS) -> None:
        check_quad_x(airframe)
        super().__init__(airframe)
        self._servo_sub: Subscription[ServoOutputs] | None = None
        self._truth_topic = TRUTH_TOPIC
        self._projection: LocalProjection | None = None

    def setup(self, physics: Physics, ctx: StepContext, topics: Mapping[str, str]) -> None:
        """Subscribe to ArduPilot's outputs; find the IMU sensors."""
        self._servo_sub = ctx.subscribe(topics["servos"], ServoOutputs)
        self._truth_topic = topics["truth"]
        self._projection = LocalProjection.at(physics.config.home)
        self._accel = physics.sensor("accelerometer")
        self._gyro = physics.sensor("gyro")

    def actuate(self, physics: Physics, ctx: StepContext) -> None:
        """Drive each rotor from its motor's output (stopped until ArduPilot drives it)."""
        sub = self._servo_sub
        assert sub is not None, "setup() was not called"
        outputs = sub.latest
        if outputs is not None:
            physics.ctrl[:] = motor_outputs(outputs.pwm, self._motors)

    def sense(self, physics: Physics, ctx: StepContext) -> None:
        """Publish the true state reached."""
        assert self._projection is not None, "setup() was not called"
        state = self.state(physics)
        ctx.publish(self._truth_topic, truth(ctx.time, state, self._projection, physics.proximity))


class ArduRoverVehicle(RoverVehicle):
    """The Ackermann rover as ArduRover's ground steering and throttle."""

    sensors: Mapping[str, str] = {"truth": TRUTH_TOPIC, "servos": SERVO_TOPIC}

    def __init__(self) -> None:
        super().__init__()
        self._servo_sub: Subscription[ServoOutputs] | None = None
        self._truth_topic = TRUTH_TOPIC
        self._projection: LocalProjection | None = None
        self._site = -1
        self._velocity = np.zeros(6)
        self._readings: list[Any] = []

    def setup(self, physics: Physics, ctx: StepContext, topics: Mapping[str, str]) -> None:
        """Find the wheels and sensors; subscribe to ArduPilot's outputs."""
        super().setup(physics, ctx, topics)
        self._servo_sub = ctx.subscribe(topics["servos"], ServoOutputs)
        self._truth_topic = topics["truth"]
        self._projection = LocalProjection.at(physics.config.home)
        self._site = physics.id(mujoco.mjtObj.mjOBJ_SITE, "sensors")
        self._readings = [
            physics.sensor(name) for name in ("position", "orientation", "accelerometer", "gyro")
        ]

    def actuate(self, physics: Physics, ctx: StepContext) -> None:
        """Steer and drive from ArduRover's steering and throttle outputs."""
        sub = self._servo_sub
        assert sub is not None, "setup() was not called"
        outputs = sub.latest
        if outputs is not None:
            self.drive(physics, *rover_command(outputs.pwm, MAX_SPEED, MAX_STEERING))

    def state(self, physics: Physics) -> NedState:
        """The rover's true state now (the rear axle's centre, its reference point)."""
        velocity = self._velocity
        # The site's velocity in the world frame: angular first, then linear.
        mujoco.mj_objectVelocity(
            physics.model, physics.data, mujoco.mjtObj.mjOBJ_SITE, self._site, velocity, 0
        )
        position, orientation, accelerometer, gyro = (r.tolist() for r in self._readings)
        v: Any = velocity[3:].tolist()
        return ned_state(position, v, orientation, accelerometer, gyro, AXLE_HEIGHT)

    def sense(self, physics: Physics, ctx: StepContext) -> None:
        """Publish the true state reached."""
        assert self._projection is not None, "setup() was not called"
        ctx.publish(self._truth_topic, truth(ctx.time, self.state(physics), self._projection))
