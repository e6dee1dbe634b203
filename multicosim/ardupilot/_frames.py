"""ArduPilot's frames on our vehicles: how its servo outputs drive them, and what it is told.

ArduPilot drives a simulator with PWM servo outputs (microseconds, as to real ESCs and
servos); a frame maps them onto one of our vehicles and names the parameters a user sets
for a new frame of that kind, so that ArduPilot's default gains fly it unchanged:

* the quadrotor (PX4's ``none_iris`` airframe): ArduCopter's quad X (``FRAME_CLASS`` 1,
  ``FRAME_TYPE`` 1) has motor 1 front-right counter-clockwise, 2 back-left
  counter-clockwise, 3 front-left clockwise, 4 back-right clockwise: the airframe's rotor
  order, so output i drives rotor i (``check_quad_x`` verifies it). The rotors' thrust
  is linear in the motor command, so ``MOT_THST_EXPO`` is 0; ``MOT_THST_HOVER`` is the
  airframe's hover throttle.
* the Ackermann rover: ArduRover's steering on output 1 (1500 us straight, more turns
  right) and throttle on output 3 (1500 us stopped); the rear drive is a speed servo, so
  throttle is a fraction of its top speed and ``CRUISE_THROTTLE`` follows from it.

No MuJoCo here: the parameters are computed before anything starts.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..core.errors import ConfigurationError
from ..core.geo import GRAVITY
from ..quadrotor.airframe import Airframe

__all__ = [
    "FRAME_RATE",
    "PWM_MAX",
    "PWM_MIN",
    "PWM_TRIM",
    "check_quad_x",
    "copter_params",
    "motor_outputs",
    "rover_command",
    "rover_params",
]

FRAME_RATE = 400
"""Hz: the physics rate ArduPilot is stepped at (``SIM_RATE_HZ``), its main loop's rate.

ArduPilot's scheduler runs one loop per 2.5 ms; a slower physics step makes every loop late
(its pre-arm check refuses "Main loop slow"), so one exchange per loop is the cheapest rate.
"""
PWM_MIN, PWM_TRIM, PWM_MAX = 1000, 1500, 2000
# ArduCopter's motor mixer output range (MOT_SPIN_MIN and MOT_SPIN_MAX defaults).
SPIN_MIN, SPIN_MAX = 0.15, 0.95

# ArduCopter's quad X, motors 1..4: (front?, right?, counter-clockwise?).
QUAD_X = ((True, True, True), (False, False, True), (True, False, False), (False, True, False))


def check_quad_x(airframe: Airframe) -> None:
    """Raise ConfigurationError unless ``airframe``'s rotors are in ArduCopter's quad X order."""
    rotors = airframe.rotors
    layout = tuple((r.x > 0, r.y > 0, r.km > 0) for r in rotors)
    if layout != QUAD_X:
        raise ConfigurationError(
            "airframe",
            airframe.name,
            "a quadrotor whose rotors are in ArduCopter's quad X order: front-right and "
            "back-left counter-clockwise, then front-left and back-right clockwise",
        )


def motor_outputs(pwm: Sequence[int], motors: int) -> list[float]:
    """The motor commands in [0, 1] for servo outputs ``pwm`` (0 us: not driven yet)."""
    span = PWM_MAX - PWM_MIN
    return [min(1.0, max(0.0, (p - PWM_MIN) / span)) for p in pwm[:motors]]


def _signed(pwm: int) -> float:
    """A servo output as a fraction of its travel from trim, in [-1, 1] (0 when not driven)."""
    if pwm <= 0:
        return 0.0
    return min(1.0, max(-1.0, (pwm - PWM_TRIM) / (PWM_MAX - PWM_TRIM)))


def rover_command(pwm: Sequence[int], max_speed: float, max_steering: float) -> tuple[float, float]:
    """(speed m/s, steering rad, + turns left) for ArduRover's outputs ``pwm``."""
    return _signed(pwm[2]) * max_speed, -_signed(pwm[0]) * max_steering


def copter_params(airframe: Airframe) -> dict[str, float]:
    """What a user sets for ``airframe`` as a new ArduCopter frame."""
    check_quad_x(airframe)
    weight = airframe.mass * GRAVITY
    command = weight / (len(airframe.rotors) * airframe.max_thrust)
    if not 0.0 < command < 1.0:
        raise ConfigurationError(
            "airframe", airframe.name, "an airframe whose rotors can lift it (hover below 100 %)"
        )
    hover = (command - SPIN_MIN) / (SPIN_MAX - SPIN_MIN)
    return {
        "FRAME_CLASS": 1,
        "FRAME_TYPE": 1,
        "MOT_PWM_MIN": PWM_MIN,
        "MOT_PWM_MAX": PWM_MAX,
        "MOT_THST_EXPO": 0.0,
        "MOT_THST_HOVER": round(min(0.8, max(0.125, hover)), 3),
        "SIM_RATE_HZ": FRAME_RATE,
    }


def rover_params(max_speed: float, cruise_speed: float = 5.0) -> dict[str, float]:
    """What a user sets for the rover as a new ArduRover frame (its cruise point)."""
    if not 0.0 < cruise_speed < max_speed:
        raise ConfigurationError("cruise_speed", cruise_speed, f"0 < speed < {max_speed:g} m/s")
    return {
        "CRUISE_SPEED": cruise_speed,
        "CRUISE_THROTTLE": round(100.0 * cruise_speed / max_speed, 1),
        "SIM_RATE_HZ": FRAME_RATE,
    }
