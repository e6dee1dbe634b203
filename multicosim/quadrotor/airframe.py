"""The quadrotor's airframe: one description for the MuJoCo model and the autopilot's mixer.

The geometry is PX4's ``none_iris`` airframe (SYS_AUTOSTART 10016, the generic quad-x that
PX4 SITL flies with an external simulator): rotor positions and moment coefficients are its
``CA_ROTORn_PX/PY/KM`` defaults, so PX4's control allocation matches the vehicle we simulate.
Mass and inertia are the Iris's (1.5 kg). Thrust is linear in the motor output, as PX4
assumes by default (``THR_MDL_FAC`` 0), with a first-order motor lag.

No MuJoCo import here: the autopilot's mixer reads the same numbers without physics.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ["NONE_IRIS", "Airframe", "Rotor"]


@dataclasses.dataclass(frozen=True)
class Rotor:
    """A rotor in the body's FRD frame (m); ``km`` > 0 spins counter-clockwise seen from above.

    ``km`` is PX4's moment coefficient: the rotor's reaction torque about the body's down axis
    is ``km`` times its thrust (a counter-clockwise rotor yaws the body clockwise).
    """

    x: float
    y: float
    km: float


@dataclasses.dataclass(frozen=True)
class Airframe:
    """A quadrotor's mass properties, rotors and motors."""

    name: str
    mass: float  # kg
    inertia: tuple[float, float, float]  # kg m^2 about the body axes
    rotors: tuple[Rotor, ...]
    max_thrust: float  # N per rotor at motor output 1.0
    motor_time_constant: float  # s, first-order lag from output to thrust
    leg_height: float = 0.1  # m from the centre of mass down to the ground contact
    prop_radius: float = 0.12  # m
    drag_coefficient: float = 1.0  # of the body in any direction, for the wind's drag
    drag_area: float = 0.06  # m^2, the reference area of that coefficient

    def mjcf(self) -> str:
        """The MuJoCo model: world frame east-north-up, body frame forward-left-up.

        Each rotor is a site actuator whose gear applies the thrust along the body's up axis
        and the reaction torque about it; ``dyntype="filter"`` makes the motor lag.
        """
        ixx, iyy, izz = self.inertia
        z0 = self.leg_height + 0.02
        sites, actuators = [], []
        for i, r in enumerate(self.rotors):
            # FRD y (right) is FLU -y; the reaction torque about "up" is -km per newton.
            sites.append(
                f'<site name="rotor{i}" pos="{r.x:g} {-r.y:g} 0.02" type="cylinder" '
                f'size="{self.prop_radius:g} 0.005"/>'
            )
            actuators.append(
                f'<general name="motor{i}" class="rotor" site="rotor{i}" '
                f'gear="0 0 1 0 0 {-r.km:g}"/>'
            )
        legs = "\n".join(
            f'<geom class="leg" pos="{sx * 0.1:g} {sy * 0.1:g} {-self.leg_height:g}"/>'
            for sx in (1, -1)
            for sy in (1, -1)
        )
        return f"""<mujoco model="{self.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.002" integrator="implicitfast" density="1.225" viscosity="1.8e-5"/>
  <default>
    <geom contype="0" conaffinity="0" rgba="0.2 0.2 0.25 1"/>
    <default class="leg">
      <geom type="sphere" size="0.02" contype="1" conaffinity="1" friction="1.0 0.01 0.001"/>
    </default>
    <default class="rotor">
      <general ctrlrange="0 1" dyntype="filter" dynprm="{self.motor_time_constant:g}"
               gainprm="{self.max_thrust:g}"/>
    </default>
  </default>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1" contype="1" conaffinity="1"/>
    <body name="vehicle" pos="0 0 {z0:g}">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="{self.mass:g}" diaginertia="{ixx:g} {iyy:g} {izz:g}"/>
      <geom name="frame" type="box" size="0.1 0.1 0.03"/>
      {legs}
      <site name="imu" pos="0 0 0"/>
      {"".join(sites)}
    </body>
  </worldbody>
  <actuator>
    {"".join(actuators)}
  </actuator>
  <sensor>
    <accelerometer name="accelerometer" site="imu"/>
    <gyro name="gyro" site="imu"/>
  </sensor>
</mujoco>
"""

    @property
    def radius(self) -> float:
        """Radius (m) of the sphere about the centre of mass that holds rotors and props."""
        arm = max(math.hypot(r.x, r.y) for r in self.rotors)
        return max(arm + self.prop_radius, self.leg_height + 0.02)

    @property
    def ground_offset(self) -> float:
        """Height (m) of the centre of mass above the ground when standing."""
        return self.leg_height + 0.02


NONE_IRIS = Airframe(
    name="none_iris",
    mass=1.5,
    inertia=(0.029125, 0.029125, 0.055225),
    rotors=(
        Rotor(0.1515, 0.245, 0.05),
        Rotor(-0.1515, -0.1875, 0.05),
        Rotor(0.1515, -0.245, -0.05),
        Rotor(-0.1515, 0.1875, -0.05),
    ),
    max_thrust=7.0,
    motor_time_constant=0.02,
)
"""PX4's generic quad-x SITL airframe (10016 ``none_iris``): Iris mass, its rotor layout."""
