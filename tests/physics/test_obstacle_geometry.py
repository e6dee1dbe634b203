"""The MuJoCo obstacles are the analytic ones: same place, same yaw, same distances."""

from __future__ import annotations

import math

import cartpole
import mujoco
import numpy as np
import pytest

import multicosim as mcs
from multicosim.physics import Box, Cylinder, Wind, World, WorldConfig
from multicosim.physics._surroundings import Surroundings
from multicosim.quadrotor.vehicle import QuadrotorVehicle

BOX = Box(length=6, width=2, height=5, north=20, east=10, yaw=30)
CYLINDER = Cylinder(radius=1.5, height=8, north=-15, east=5)


@pytest.fixture
def scene() -> tuple[Surroundings, object, object]:
    vehicle = QuadrotorVehicle()
    surroundings = Surroundings(WorldConfig(obstacles=(BOX, CYLINDER)), vehicle.body)
    spec = vehicle.load_model()
    surroundings.attach(spec)
    surroundings.attach_sphere(spec)
    model = spec.compile()
    surroundings.bind(model, seed=0, dt=0.01)
    return surroundings, model, mujoco.MjData(model)


def place(model: object, data: object, north: float, east: float, up: float) -> None:
    data.qpos[:3] = (east, north, up)  # type: ignore[attr-defined]
    data.qpos[3:7] = (1, 0, 0, 0)  # type: ignore[attr-defined]
    mujoco.mj_forward(model, data)


def along(
    north: float, east: float, yaw_deg: float, ahead: float, right: float
) -> tuple[float, float]:
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    return north + ahead * c - right * s, east + ahead * s + right * c


@pytest.mark.parametrize(
    ("ahead", "right", "touching"),
    [
        (3.0 + 0.3, 0.0, True),  # 0.3 m beyond the box's far end: inside the 0.41 m sphere
        (3.0 + 0.6, 0.0, False),
        (0.0, 1.0 + 0.3, True),  # beside its long side
        (0.0, 1.0 + 0.6, False),
        (-3.0 - 0.3, 0.5, True),
    ],
)
def test_mujoco_contacts_where_the_yawed_box_is(
    scene: tuple[Surroundings, object, object], ahead: float, right: float, touching: bool
) -> None:
    surroundings, model, data = scene
    north, east = along(20, 10, 30, ahead, right)
    place(model, data, north, east, 2.5)
    proximity = surroundings.measure(model, data, 1.0)
    assert (proximity.contact == 0) is touching
    analytic = max(abs(ahead) - 3.0, 0.0) + max(abs(right) - 1.0, 0.0) - surroundings.body.radius
    assert proximity.clearance == pytest.approx(analytic, abs=1e-9)


def test_mujoco_distances_equal_the_analytic_ones(
    scene: tuple[Surroundings, object, object],
) -> None:
    surroundings, model, data = scene
    sphere = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "obstacle_contact")
    rng = np.random.default_rng(1)
    for p in surroundings.placed:
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"obstacle{p.number}")
        for _ in range(20):
            north = p.north + rng.uniform(-8, 8)
            east = p.east + rng.uniform(-8, 8)
            up = rng.uniform(0.5, 12)
            place(model, data, north, east, up)
            expected = p.distance(north, east, up) - surroundings.body.radius
            if expected <= 0.05:
                continue  # MuJoCo's distance is for separated shapes
            fromto = np.zeros(6)
            measured = mujoco.mj_geomDistance(model, data, sphere, geom, 50.0, fromto)
            assert measured == pytest.approx(expected, abs=1e-3)


@pytest.mark.parametrize(
    ("config", "field"),
    [
        (WorldConfig(wind=Wind(speed=3.0)), "wind"),
        (WorldConfig(obstacles=(CYLINDER,)), "obstacles"),
    ],
)
def test_a_vehicle_without_a_body_cannot_fly_among_obstacles_or_in_wind(
    config: WorldConfig, field: str
) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        World(config, cartpole.CartPole())
    assert info.value.field == field
    assert "physics.Bodied" in info.value.allowed
