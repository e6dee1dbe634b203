"""One MuJoCo model from a fleet's vehicles (see [`fleet`][multicosim.fleet]): each vehicle's bodies
attached under its name at its start pose, the ground, the obstacles, one air."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import mujoco

from ..core.errors import ConfigurationError
from .fleet import CONTACT_GEOM, frame_quat, resolve_pose

if TYPE_CHECKING:
    from .config import WorldConfig
    from .wind import Body

__all__ = ["assemble"]

_VEHICLE_AFFINITY = 4  # contact bit of vehicle spheres: obstacles use 2, the ground 1

# What of a vehicle's model is the world's to set, so that attaching it raises no conflict:
# the world's options (MuJoCo warns when an attached model's differ).
_OPTIONS = (
    "timestep",
    "density",
    "viscosity",
    "integrator",
    "solver",
    "cone",
    "jacobian",
    "iterations",
    "tolerance",
    "ls_iterations",
    "noslip_iterations",
    "impratio",
    "gravity",
    "wind",
    "magnetic",
)


def _bodies(spec: Any) -> list[Any]:
    body = spec.worldbody.first_body()
    found = []
    while body is not None:
        found.append(body)
        body = spec.worldbody.next_body(body)
    return found


def assemble(
    config: WorldConfig, members: Sequence[Any], bodies: Mapping[str, Body | None]
) -> tuple[Any, list[tuple[slice, ...]]]:
    """The compiled model of ``members`` (the world's ``_Member``), and each one's ``qpos``,
    ``qvel``, ``ctrl`` and ``sensordata`` slices, in order; ``bodies`` are the bodies the
    vehicles describe (None: none), which touch each other's."""
    specs = []
    for member in members:
        spec = member.vehicle.load_model()
        if not isinstance(spec, mujoco.MjSpec):
            raise ConfigurationError(
                f"vehicles[{member.name!r}]",
                member.vehicle,
                "a vehicle whose load_model() returns an MjSpec (several vehicles share one "
                "model, built from theirs)",
            )
        specs.append(spec)
    world = mujoco.MjSpec()
    world.worldbody.add_geom(
        name="ground",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 1.0],
        contype=1,
        conaffinity=1,
    )
    # The air is one: as dense and viscous as the model that asks most of it.
    world.option.density = max(s.option.density for s in specs)
    world.option.viscosity = max(s.option.viscosity for s in specs)
    views = []
    start = [0, 0, 0, 0]
    for member, spec in zip(members, specs, strict=True):
        alone = spec.compile()  # its sizes: the attached copy keeps them, in attach order
        sizes = (alone.nq, alone.nv, alone.nu, alone.nsensordata)
        views.append(tuple(slice(a, a + n) for a, n in zip(start, sizes, strict=True)))
        start = [a + n for a, n in zip(start, sizes, strict=True)]
        for field in _OPTIONS:
            setattr(spec.option, field, getattr(world.option, field))
        north, east, up, yaw = resolve_pose(member.pose, config.home)
        frame = world.worldbody.add_frame(pos=[east, north, up], quat=frame_quat(yaw))
        for body in _bodies(spec):
            frame.attach_body(body, f"{member.name}/", "")
    if members and members[0].surroundings is not None:
        members[0].surroundings.attach(world)
    for member in members:
        if member.surroundings is not None:
            member.surroundings.attach_sphere(world)
        body = bodies.get(member.name)
        if body is not None:
            # A sphere of the body's radius that touches only other vehicles' (a contact
            # between two of them is a collision; the ground and obstacles see none of it).
            world.body(f"{member.name}/{body.name}").add_geom(
                name=f"{member.name}/{CONTACT_GEOM}",
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                size=[body.radius, 0.0, 0.0],
                contype=_VEHICLE_AFFINITY,
                conaffinity=_VEHICLE_AFFINITY,
                rgba=(0.0, 0.0, 0.0, 0.0),
            )
    return world.compile(), views
