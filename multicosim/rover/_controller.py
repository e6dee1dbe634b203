"""The rover controller firmware: the automaton in a control loop on the simulated clock.

``python -m multicosim serve multicosim.rover:controller --port {port}`` serves it; each
[`Mission`][multicosim.rover._controller.Mission] sent to it is flown to the end and answered with
its [`Trajectory`][multicosim.rover._controller.Trajectory].
"""

from __future__ import annotations

from ..core.errors import MulticosimError
from ..runtime.context import FirmwareContext
from ..runtime.serve import firmware
from ._automaton import Automaton, Observation
from ._messages import (
    ABORT_TOPIC,
    COMMAND_TOPIC,
    SENSOR_TOPICS,
    Abort,
    Imu,
    MagneticField,
    Mission,
    Position,
    SensedSample,
    Trajectory,
    WheelSpeed,
)
from ._vehicle import heading_from_field, roll_from_quaternion

__all__ = ["CONTROL_PERIOD", "SENSOR_TIMEOUT", "STOPPED_SPEED", "controller"]

CONTROL_PERIOD = 0.05  # s, the default; a mission's ``rate`` overrides it
SENSOR_TIMEOUT = 2.0  # s of simulated time to wait for the first sensor readings
STOPPED_SPEED = 0.05  # m/s: below this the rover counts as stopped
SETTLE_TIMEOUT = 10.0  # s: longest the controller waits for the rover to stop at the end


@firmware(msgtype=Mission, period=CONTROL_PERIOD)
def controller(mission: Mission, ctx: FirmwareContext) -> Trajectory:
    """Drive ``mission`` on sensor data; reply with the trajectory the controller sensed."""
    position = ctx.subscribe(SENSOR_TOPICS["position"], Position)
    compass = ctx.subscribe(SENSOR_TOPICS["magnetometer"], MagneticField)
    imu = ctx.subscribe(SENSOR_TOPICS["imu"], Imu)
    odometry = ctx.subscribe(SENSOR_TOPICS["wheel_speed"], WheelSpeed)
    aborts = ctx.subscribe(ABORT_TOPIC, Abort)
    dt = 1.0 / mission.rate

    ctx.step()
    # A newly started handler first receives the last message of each topic: an abort
    # published before this mission belongs to an earlier one.
    abort_reason: str | None = None
    if aborts.messages and (aborts.latest_time or 0.0) >= ctx.time:
        abort_reason = aborts.messages[0].reason
    deadline = ctx.time + SENSOR_TIMEOUT
    while position.latest is None or compass.latest is None or odometry.latest is None:
        if ctx.time >= deadline:
            missing = [sub.topic for sub in (position, compass, odometry) if sub.latest is None]
            raise MulticosimError(
                f"no sensor data on {', '.join(missing)} after {SENSOR_TIMEOUT:g} s: "
                "is a rover world in the simulation?"
            )
        ctx.step(dt)
        if abort_reason is None and aborts.messages:
            abort_reason = aborts.messages[0].reason

    start = ctx.time
    automaton = Automaton(mission, start)
    samples: list[SensedSample] = []
    while True:
        pos, field, wheels = position.latest, compass.latest, odometry.latest
        assert pos is not None
        assert field is not None
        assert wheels is not None
        now = ctx.time
        heading = heading_from_field(field.x, field.y)
        orientation = imu.latest.orientation if imu.latest is not None else (1.0, 0.0, 0.0, 0.0)
        if abort_reason is None:
            if aborts.messages and samples:
                abort_reason = aborts.messages[0].reason
            elif mission.abort_at is not None and now - start >= mission.abort_at - 1e-9:
                abort_reason = f"abort at {mission.abort_at:g} s"
        obs = Observation(time=now, x=pos.x, y=pos.y, heading=heading, speed=wheels.speed)
        command = automaton.update(obs, abort_reason)
        # Set-points are streamed every period, like a real controller's.
        ctx.publish(COMMAND_TOPIC, command)
        samples.append(
            SensedSample(
                time=now,
                x=pos.x,
                y=pos.y,
                z=pos.z,
                heading=heading,
                roll=roll_from_quaternion(orientation),
                speed=wheels.speed,
                state=automaton.state.value,
            )
        )
        if automaton.terminal and (
            abs(wheels.speed) < STOPPED_SPEED or now - automaton.entered >= SETTLE_TIMEOUT
        ):
            break
        ctx.step(dt)

    return Trajectory(
        samples=samples,
        final_state=automaton.state.value,
        completed=automaton.completed,
        reason=automaton.reason,
        start_time=start,
    )
