"""The world around the vehicle in MuJoCo: obstacle geometry, the wind's drag, collisions.

Obstacles become static geoms of the world body, colliding only with a sphere the world adds
to the vehicle's body (its [`Body`][multicosim.physics.wind.Body] radius), so a contact
between them is a collision and nothing else changes (the ground, the vehicle's own geoms).
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from .config import WorldConfig
from .obstacles import NO_OBSTACLES, ClearanceMonitor, Proximity, placed
from .wind import Body, WindField, drag_force, wind_generator

__all__ = ["Surroundings"]

# Contact bits: obstacles collide with the vehicle's sphere and with nothing else.
_OBSTACLE_AFFINITY = 2
_OBSTACLE_RGBA = (0.8, 0.45, 0.2, 1.0)


class Surroundings:
    """Obstacles and wind of ``config`` around the vehicle ``body`` (of fleet vehicle
    ``member``, whose objects are named ``member/...``; "" for a world of one vehicle)."""

    def __init__(self, config: WorldConfig, body: Body, member: str = "") -> None:
        self.config = config
        self.body = body
        self._prefix = f"{member}/" if member else ""
        self.placed = placed(config.obstacles, config.home)
        self.monitor = ClearanceMonitor(self.placed, body.radius)
        self.wind: WindField | None = None
        self._geoms: dict[int, int] = {}
        self._body_id = -1
        self._velocity = np.zeros(6)
        self.air: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._last = (0.0, 0.0, 0.0, -1.0)  # the body's position at the last measure, and when

    def attach(self, spec: Any) -> None:
        """Add the obstacles to the model's spec (once per world)."""
        for p in self.placed:
            name = f"obstacle{p.number}"
            pos = [p.east, p.north, p.height / 2]
            if p.radius:
                spec.worldbody.add_geom(
                    name=name,
                    type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                    size=[p.radius, p.height / 2, 0.0],
                    pos=pos,
                    contype=0,
                    conaffinity=_OBSTACLE_AFFINITY,
                    rgba=_OBSTACLE_RGBA,
                )
            else:
                # The length axis (geom x) points yaw clockwise from north: in ENU that is
                # a turn of 90 deg - yaw about up.
                turn = math.pi / 2 - p.yaw
                spec.worldbody.add_geom(
                    name=name,
                    type=mujoco.mjtGeom.mjGEOM_BOX,
                    size=[p.half_length, p.half_width, p.height / 2],
                    pos=pos,
                    quat=[math.cos(turn / 2), 0.0, 0.0, math.sin(turn / 2)],
                    contype=0,
                    conaffinity=_OBSTACLE_AFFINITY,
                    rgba=_OBSTACLE_RGBA,
                )

    def attach_sphere(self, spec: Any) -> None:
        """Add the vehicle's collision sphere to its body in the model's spec."""
        if not self.placed:
            return
        vehicle = spec.body(self._prefix + self.body.name)
        vehicle.add_geom(
            name=self._prefix + "obstacle_contact",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[self.body.radius, 0.0, 0.0],
            contype=_OBSTACLE_AFFINITY,
            conaffinity=0,
            rgba=(0.0, 0.0, 0.0, 0.0),
        )

    def bind(self, model: Any, seed: int, dt: float) -> None:
        """Find the compiled ids; seed the wind."""
        name = self._prefix + self.body.name
        self._body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        for p in self.placed:
            gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"obstacle{p.number}")
            self._geoms[gid] = p.number
        if self.config.wind is not None:
            self.wind = WindField(self.config.wind, dt, wind_generator(seed))

    def _body_velocity(self, model: Any, data: Any) -> tuple[float, float, float]:
        v = self._velocity
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, self._body_id, v, 0)
        return (float(v[3]), float(v[4]), float(v[5]))

    def blow(self, model: Any, data: Any, time: float) -> None:
        """Apply the wind's drag for the period starting at ``time`` (a constant force)."""
        wind = self.wind
        if wind is None:
            return
        i = self._body_id
        north, east, up = wind.step(time, float(data.xpos[i, 2]))
        self.air = (north, east, up)
        force = drag_force(self.body, (east, north, up), self._body_velocity(model, data))
        data.xfrc_applied[i, :3] = force

    def measure(self, model: Any, data: Any, time: float) -> Proximity:
        """Clearances and collisions for the state reached at ``time``."""
        if not self.placed:
            return NO_OBSTACLES
        contact = -1
        n = data.ncon
        if n:
            geoms = self._geoms
            for g1, g2 in data.contact.geom[:n].tolist():
                hit = geoms.get(g1, geoms.get(g2, -1))
                if hit >= 0:
                    contact = hit
                    break
        x, y, z = data.xpos[self._body_id].tolist()
        speed = 0.0
        if contact >= 0 and self.monitor.proximity.hit < 0:
            speed = math.hypot(*self._body_velocity(model, data))
            # The contact may have stopped the body within the period: it came in at least
            # as fast as it covered the period.
            lx, ly, lz, lt = self._last
            if 0.0 <= lt < time:
                speed = max(speed, math.hypot(x - lx, y - ly, z - lz) / (time - lt))
        self._last = (x, y, z, time)
        return self.monitor.update(time, y, x, z, speed, contact)
