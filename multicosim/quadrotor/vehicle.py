"""The quadrotor in MuJoCo: the vehicle plug-in of the world that PX4 (ours or the real one) flies.

``python -m multicosim participant multicosim.px4.world:world --config JSON`` runs it as a
process. It reads HIL_ACTUATOR_CONTROLS (four motor outputs in [0, 1] while armed) and
publishes PX4's sensor messages through ``HilSensors``.

MuJoCo's frames are east-north-up (world) and forward-left-up (body); PX4's are
north-east-down and forward-right-down: ``ned_state``
converts the vehicle's state once per period.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import mujoco

from ..core.errors import ConfigurationError
from ..mavlink.dialect import MODE_FLAG_ARMED
from ..mavlink.hil import ACTUATOR_FLAG_VELOCITY, HilActuatorControls, MavlinkPacket, Wire, read
from ..physics.frames import NedState, ned_state
from ..physics.wind import Body
from ..physics.world import Physics
from .airframe import NONE_IRIS, Airframe
from .sensors import HilSensors
from .topics import SENSORS, Topics

if TYPE_CHECKING:
    from ..runtime.context import StepContext, Subscription

__all__ = ["QuadrotorVehicle"]


class QuadrotorVehicle:
    """A quadrotor built from an ``Airframe`` (PX4's none_iris).

    Motor outputs drive the rotors only while the HIL_ACTUATOR_CONTROLS mode says armed
    (as PX4's simulators do); sensors come out on the world's topics in ``wire`` form, every
    ``period`` seconds (None: every world period; else a whole number of them, its
    autopilot's rate where the world runs faster for another vehicle).
    """

    sensors: Mapping[str, str] = {name: getattr(Topics(), name) for name in SENSORS}

    def __init__(
        self, airframe: Airframe = NONE_IRIS, wire: Wire = "native", period: float | None = None
    ) -> None:
        self.airframe = airframe
        self.wire = wire
        self.period = period
        self._every = 1
        self._steps = 0
        self._actuators: Subscription[Any] | None = None
        self._hil: HilSensors | None = None
        self._cmd: HilActuatorControls | None = None
        self._motors = len(airframe.rotors)
        self.body = Body("vehicle", airframe.radius, airframe.drag_coefficient, airframe.drag_area)

    def load_model(self) -> Any:
        """The MJCF model generated from the airframe (a spec: the world adds obstacles)."""
        return mujoco.MjSpec.from_string(self.airframe.mjcf())

    def setup(self, physics: Physics, ctx: StepContext, topics: Mapping[str, str]) -> None:
        """Subscribe to the actuator outputs; set up the sensor suite."""
        world_period = physics.config.period
        period = world_period if self.period is None else self.period
        self._every = max(1, round(period / world_period))
        if abs(self._every * world_period - period) > 1e-9:
            raise ConfigurationError(
                "period", period, f"a whole number of the world's period ({world_period:g} s)"
            )
        self._hil = HilSensors(physics.config, period, self.wire, topics=Topics(**topics))
        self._hil.setup(ctx)
        tp = MavlinkPacket if self.wire == "mavlink" else HilActuatorControls
        self._actuators = ctx.subscribe(self._hil.topics.actuators, tp)
        self._accel = physics.sensor("accelerometer")
        self._gyro = physics.sensor("gyro")

    def actuate(self, physics: Physics, ctx: StepContext) -> None:
        """Apply the latest motor outputs (zero while disarmed)."""
        sub = self._actuators
        assert sub is not None, "setup() was not called"
        if sub.fresh:
            latest = sub.latest
            self._cmd = read(latest, HilActuatorControls) if self.wire == "mavlink" else latest
        cmd = self._cmd
        ctrl = physics.ctrl
        if (
            cmd is not None
            and cmd.mode & MODE_FLAG_ARMED
            and not cmd.flags & ACTUATOR_FLAG_VELOCITY
        ):
            ctrl[:] = cmd.controls[: self._motors]
        else:
            ctrl[:] = 0.0

    def sense(self, physics: Physics, ctx: StepContext) -> None:
        """Publish PX4's sensor messages for the state reached (when they are due)."""
        hil = self._hil
        assert hil is not None, "setup() was not called"
        due = self._steps % self._every == 0
        self._steps += 1
        if due:
            hil.publish(ctx, *self.state(physics), proximity=physics.proximity)

    def state(self, physics: Physics) -> NedState:
        """The vehicle's true state now, in NED/FRD (from MuJoCo's ENU/FLU)."""
        qpos = physics.qpos.tolist()
        return ned_state(
            qpos[:3],
            physics.qvel[:3].tolist(),
            qpos[3:7],
            self._accel.tolist(),
            self._gyro.tolist(),
            self.airframe.ground_offset,
        )
