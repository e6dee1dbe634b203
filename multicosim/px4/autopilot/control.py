"""The cascaded multicopter controller: position -> velocity -> attitude -> rate -> mixer.

The position stage runs for every vehicle. The point-mass vehicle of the low-fidelity world
takes the velocity setpoint directly (its first-order velocity response stands in for the
inner loops); the MuJoCo quadrotor gets the whole cascade down to four motor outputs.
Gains are tuned for PX4's none_iris airframe (1.5 kg, ``multicosim.quadrotor.airframe``).
"""

from __future__ import annotations

import math

import numpy as np

from ...core.geo import GRAVITY
from ...quadrotor.airframe import NONE_IRIS, Airframe
from .estimator import rotation_matrix

__all__ = ["MultirotorController", "Vehicle", "position_control"]

HOVER_THRUST = 0.5  # PX4's MPC_THR_HOVER: the normalized thrust that hovers


class Vehicle:
    """What the mixer and thrust model need, derived from the airframe the world simulates.

    The allocation is PX4's: the effectiveness matrix (collective thrust and FRD torques per
    rotor thrust) inverted once, so any quad layout (the Iris's is not square) mixes exactly.
    """

    def __init__(self, airframe: Airframe = NONE_IRIS) -> None:
        self.mass = airframe.mass
        self.inertia = airframe.inertia
        self.max_thrust = airframe.max_thrust
        # Rows: thrust, roll, pitch, yaw per newton of each rotor (FRD, thrust along -z).
        effectiveness = np.array(
            [
                [1.0] * len(airframe.rotors),
                [-r.y for r in airframe.rotors],
                [r.x for r in airframe.rotors],
                [r.km for r in airframe.rotors],
            ]
        )
        alloc = np.linalg.pinv(effectiveness)
        # Per rotor: newtons per N of thrust, per N m of roll, pitch and yaw torque.
        self.alloc: list[tuple[float, float, float, float]] = [
            (float(a[0]), float(a[1]), float(a[2]), float(a[3])) for a in alloc
        ]


VEL_P_XY = 1.8
"""1/s: the horizontal velocity loop's gain (PX4's MPC_XY_VEL_P_ACC default)."""
VEL_I_XY = 0.4
"""1/s²: the horizontal velocity loop's integral gain (PX4's MPC_XY_VEL_I_ACC default)."""
ARW_GAIN = 2.0 / VEL_P_XY
"""s: how much of the acceleration the tilt limit cuts is taken off the integrated error."""


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


def position_control(
    pos: list[float],
    sp: tuple[float, float, float],
    *,
    cruise: float,
    up: float,
    down: float,
    vz_override: float | None = None,
    origin: tuple[float, float] | None = None,
    kp_xy: float = 0.95,
    kp_z: float = 1.5,
) -> tuple[float, float, float]:
    """Velocity setpoint (NED) towards position ``sp``, limited like PX4's MPC_* speeds.

    Saturating the horizontal error as one vector keeps the path a straight line in still
    air. With ``origin`` (north, east: where the leg began) the vehicle flies the line from
    it to ``sp``, as PX4's auto modes do: the error across the line is corrected first and
    the rest of the speed goes along it, so a crosswind does not bend the path.
    """
    ex, ey = sp[0] - pos[0], sp[1] - pos[1]
    lx, ly = (sp[0] - origin[0], sp[1] - origin[1]) if origin is not None else (0.0, 0.0)
    length = math.hypot(lx, ly)
    if length > 1.0:
        ux, uy = lx / length, ly / length
        along = ex * ux + ey * uy  # still to go along the line
        cx, cy = kp_xy * (ex - along * ux), kp_xy * (ey - along * uy)  # back onto the line
        across = math.hypot(cx, cy)
        if across > cruise:
            cx, cy, across = cx * cruise / across, cy * cruise / across, cruise
        room = math.sqrt(cruise * cruise - across * across)
        va = _clamp(kp_xy * along, -room, room)
        vx, vy = cx + va * ux, cy + va * uy
    else:
        vx, vy = kp_xy * ex, kp_xy * ey
        h = math.hypot(vx, vy)
        if h > cruise:
            vx, vy = vx * cruise / h, vy * cruise / h
    vz = kp_z * (sp[2] - pos[2]) if vz_override is None else vz_override
    return vx, vy, _clamp(vz, -up, down)


class MultirotorController:
    """Velocity, attitude and rate loops plus the quad-x mixer; outputs motor commands 0..1."""

    def __init__(self, vehicle: Vehicle | None = None) -> None:
        self.v = vehicle or Vehicle()
        self.vel_int = [0.0, 0.0, 0.0]
        self.rate_int = [0.0, 0.0, 0.0]
        self.prev_rates = (0.0, 0.0, 0.0)
        self.max_tilt = math.radians(35.0)
        self.thrust = 0.0  # last collective thrust (N), for the land detector

    def reset(self) -> None:
        """Clear integrators (on the ground, and when disarmed)."""
        self.vel_int = [0.0, 0.0, 0.0]
        self.rate_int = [0.0, 0.0, 0.0]

    def update(
        self,
        dt: float,
        vel: list[float],
        vel_sp: tuple[float, float, float],
        yaw_sp: float,
        r: tuple[float, ...],
        rates: tuple[float, float, float],
    ) -> list[float]:
        """One control cycle: motor commands for velocity ``vel_sp`` and heading ``yaw_sp``."""
        v = self.v
        # Velocity loop -> acceleration setpoint (NED).
        vi = self.vel_int
        ex, ey, ez = vel_sp[0] - vel[0], vel_sp[1] - vel[1], vel_sp[2] - vel[2]
        vi[2] = _clamp(vi[2] + ez * dt, -3.0, 3.0)
        ax = VEL_P_XY * ex + VEL_I_XY * vi[0]
        ay = VEL_P_XY * ey + VEL_I_XY * vi[1]
        az = 4.0 * ez + 2.0 * vi[2]
        # Thrust vector: F = m (a - g); body z must point along -F.
        fx, fy, fz = v.mass * ax, v.mass * ay, v.mass * (az - GRAVITY)
        fz = min(fz, -0.2 * v.mass * GRAVITY)  # never command thrust downwards
        horiz = math.hypot(fx, fy)
        max_h = -fz * math.tan(self.max_tilt)
        if horiz > max_h:
            # Anti-reset windup as PX4's: while the tilt limit cuts the acceleration, the
            # integrator learns from the error less what was cut (so it may grow as large
            # as a steady wind needs, but not wind up in a fast move).
            cut = 1.0 - max_h / horiz
            ex -= ARW_GAIN * ax * cut
            ey -= ARW_GAIN * ay * cut
            fx, fy = fx * max_h / horiz, fy * max_h / horiz
        vi[0] += ex * dt
        vi[1] += ey * dt
        norm = math.sqrt(fx * fx + fy * fy + fz * fz)
        zx, zy, zz = -fx / norm, -fy / norm, -fz / norm  # desired body z (down) axis, in NED
        # Collective thrust: the force's component along the current body z axis.
        thrust = max(0.0, -(fx * r[2] + fy * r[5] + fz * r[8]))
        self.thrust = thrust
        # Desired attitude from z axis and yaw (x axis as close to the heading as possible).
        cy, sy = math.cos(yaw_sp), math.sin(yaw_sp)
        # y_d = z_d x x_c, with x_c the heading direction in the horizontal plane.
        yx, yy, yz = zy * 0.0 - zz * sy, zz * cy - zx * 0.0, zx * sy - zy * cy
        n = math.sqrt(yx * yx + yy * yy + yz * yz)
        yx, yy, yz = yx / n, yy / n, yz / n
        xx, xy, xz = yy * zz - yz * zy, yz * zx - yx * zz, yx * zy - yy * zx
        rd = (xx, yx, zx, xy, yy, zy, xz, yz, zz)
        return self._attitude_rate(dt, rd, thrust, r, rates)

    def attitude(
        self,
        dt: float,
        q_sp: tuple[float, float, float, float],
        thrust: float,
        r: tuple[float, ...],
        rates: tuple[float, float, float],
    ) -> list[float]:
        """Motor commands for attitude ``q_sp`` (w, x, y, z) and normalized ``thrust``.

        Thrust 0..1 as PX4's attitude setpoints give it, scaled so that MPC_THR_HOVER (0.5)
        holds the vehicle's weight.
        """
        w, x, y, z = q_sp
        n = math.sqrt(w * w + x * x + y * y + z * z) or 1.0
        w, x, y, z = w / n, x / n, y / n, z / n
        rd = rotation_matrix(w, x, y, z)
        force = _clamp(thrust, 0.0, 1.0) / HOVER_THRUST * self.v.mass * GRAVITY
        self.thrust = force
        return self._attitude_rate(dt, rd, force, r, rates)

    def _attitude_rate(
        self,
        dt: float,
        rd: tuple[float, ...],
        thrust: float,
        r: tuple[float, ...],
        rates: tuple[float, float, float],
    ) -> list[float]:
        """Attitude and rate loops: motor commands for attitude ``rd`` (row-major, to NED)."""
        v = self.v
        # Attitude error e_R = vee(Rd^T R - R^T Rd) / 2 (geometric control, body frame).
        m = [0.0] * 9  # M = Rd^T R
        for i in range(3):
            for j in range(3):
                m[3 * i + j] = rd[i] * r[j] + rd[3 + i] * r[3 + j] + rd[6 + i] * r[6 + j]
        erx = 0.5 * (m[7] - m[5])
        ery = 0.5 * (m[2] - m[6])
        erz = 0.5 * (m[3] - m[1])
        # Attitude loop -> body rate setpoint; rate loop -> torque.
        lim_rp, lim_y = math.radians(220.0), math.radians(200.0)
        pr = _clamp(-6.5 * erx, -lim_rp, lim_rp)
        qr = _clamp(-6.5 * ery, -lim_rp, lim_rp)
        rr = _clamp(-2.8 * erz, -lim_y, lim_y)
        ri = self.rate_int
        e0, e1, e2 = pr - rates[0], qr - rates[1], rr - rates[2]
        ri[0] = _clamp(ri[0] + e0 * dt, -0.3, 0.3)
        ri[1] = _clamp(ri[1] + e1 * dt, -0.3, 0.3)
        ri[2] = _clamp(ri[2] + e2 * dt, -0.3, 0.3)
        d0 = (rates[0] - self.prev_rates[0]) / dt if dt > 0 else 0.0
        d1 = (rates[1] - self.prev_rates[1]) / dt if dt > 0 else 0.0
        self.prev_rates = rates
        jx, jy, jz = v.inertia
        tx = jx * (18.0 * e0 + 6.0 * ri[0] - 0.25 * d0)
        ty = jy * (18.0 * e1 + 6.0 * ri[1] - 0.25 * d1)
        tz = jz * (9.0 * e2 + 3.0 * ri[2])
        return self.mix(thrust, tx, ty, tz)

    def mix(self, thrust: float, tx: float, ty: float, tz: float) -> list[float]:
        """Rotor commands (0..1) for collective thrust (N) and body torques (N m, FRD).

        Saturation is resolved as PX4's mixer does: roll/pitch are scaled to fit around the
        collective thrust first, yaw gets whatever headroom is left.
        """
        v = self.v
        mt = v.max_thrust
        alloc = v.alloc
        base = [a[0] * thrust for a in alloc]
        rp = [a[1] * tx + a[2] * ty for a in alloc]
        scale = 1.0
        for b, x in zip(base, rp, strict=True):
            b = _clamp(b, 0.0, mt)
            room = min(b, mt - b)
            if abs(x) * scale > room:
                scale = room / abs(x) if x else scale
        base = [_clamp(b, 0.0, mt) for b in base]
        rp = [x * scale for x in rp]
        yaw = [a[3] * tz for a in alloc]
        # The largest fraction of the yaw torque every rotor has headroom for.
        k = 1.0
        for b, x, y in zip(base, rp, yaw, strict=True):
            f = b + x
            room = mt - f if y > 0 else f
            if abs(y) > max(room, 0.0):
                k = min(k, max(room, 0.0) / abs(y))
        return [
            _clamp((b + x + k * y) / mt, 0.0, 1.0) for b, x, y in zip(base, rp, yaw, strict=True)
        ]
