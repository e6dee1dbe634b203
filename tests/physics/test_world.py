"""The MuJoCo world: configuration, physics stepping, sensors and commands, real MuJoCo."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from typing import Any

import msgspec
import pytest

import multicosim as mcs
from multicosim.core.geo import Home
from multicosim.physics import (
    DEFAULT_HOME,
    INTEGRATORS,
    SOLVERS,
    WorldConfig,
    geodetic_to_local,
    local_to_geodetic,
)
from multicosim.rover import (
    COMMAND_TOPIC,
    SENSOR_TOPICS,
    TRACK,
    WHEEL_RADIUS,
    WHEEL_WIDTH,
    WHEELBASE,
    Command,
    Imu,
    MagneticField,
    Position,
    RoverWorldConfig,
    WheelSpeed,
    heading_from_field,
)

mujoco = pytest.importorskip("mujoco")

from multicosim.physics import Physics, World  # noqa: E402
from multicosim.rover import RoverVehicle, rover_world  # noqa: E402

# -- configuration --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("timestep", 0.0),
        ("timestep", -0.001),
        ("timestep", 0.2),
        ("timestep", math.nan),
        ("timestep", True),
        ("integrator", "Verlet"),
        ("integrator", "euler"),
        ("solver", "Dantzig"),
        ("iterations", 0),
        ("iterations", 2.5),
        ("period", 0.0001),
        ("period", 2.0),
        ("sensor_topics", {"imu": ""}),
        ("home", (91.0, 0.0, 0.0)),
        ("home", (0.0, 181.0, 0.0)),
        ("home", (0.0, 0.0)),
        ("magnetic_field", (0.0, 1.0)),
    ],
)
def test_invalid_world_config_names_the_field(field: str, value: Any) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        WorldConfig(**{field: value})
    assert info.value.field == field
    assert field in str(info.value)


def test_world_config_defaults_and_variants() -> None:
    config = WorldConfig()
    assert config.home == DEFAULT_HOME == (47.397742, 8.545594, 488.0)
    assert config.steps_per_period == 5
    fine = dataclasses.replace(config, timestep=0.0005, integrator="RK4")
    assert fine.steps_per_period == 20
    with pytest.raises(mcs.ConfigurationError, match="iterations"):
        dataclasses.replace(config, iterations=0)


def test_world_config_round_trips_through_json() -> None:
    config = WorldConfig(
        timestep=0.001, solver="PGS", sensor_topics={"imu": "raw/imu"}, home=Home(10.0, 20.0, 5.0)
    )
    decoded = msgspec.json.decode(msgspec.json.encode(config), type=WorldConfig)
    assert decoded == config
    with pytest.raises(msgspec.ValidationError, match="integrator"):
        msgspec.json.decode(b'{"integrator": "Verlet"}', type=WorldConfig)


def test_unknown_sensor_in_remapping_is_rejected() -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        RoverWorldConfig(world=WorldConfig(sensor_topics={"lidar": "x"}))
    assert info.value.field == "sensor_topics"


# -- geodesy --------------------------------------------------------------------------------


def test_geodetic_projection() -> None:
    home = DEFAULT_HOME
    assert local_to_geodetic(home, east=0.0, north=0.0, up=0.0) == home
    lat, lon, alt = local_to_geodetic(home, east=0.0, north=1000.0, up=2.0)
    assert lat > home[0]
    assert lon == pytest.approx(home[1], abs=1e-12)
    assert (lat - home[0]) * math.pi / 180 * 6_371_000 == pytest.approx(1000.0, rel=1e-6)
    assert alt == pytest.approx(490.0)
    for east, north in [(123.0, -45.0), (-2000.0, 3000.0)]:
        back = geodetic_to_local(home, *local_to_geodetic(home, east=east, north=north, up=1.0))
        assert (back.east, back.north, back.up) == pytest.approx((east, north, 1.0), abs=1e-6)


# -- physics --------------------------------------------------------------------------------


def test_physics_applies_the_configuration() -> None:
    config = WorldConfig(timestep=0.001, integrator="RK4", solver="CG", iterations=7)
    physics = Physics.from_xml_path(RoverVehicle.model_path, config)
    opt = physics.model.opt
    assert opt.timestep == 0.001
    assert opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert opt.solver == mujoco.mjtSolver.mjSOL_CG
    assert opt.iterations == 7
    assert physics.step_to(0.01) == 10
    assert physics.step_to(0.01) == 0
    assert physics.step_to(0.0125) == 2  # rounded to whole steps, never drifting
    assert physics.data.time == pytest.approx(0.012)


def test_model_matches_the_rover_geometry() -> None:
    physics = Physics.from_xml_path(RoverVehicle.model_path, WorldConfig())
    model = physics.model

    def body_pos(name: str) -> Any:
        return model.body_pos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)]

    front = body_pos("front_left_knuckle")
    rear_left, rear_right = body_pos("rear_left_wheel"), body_pos("rear_right_wheel")
    assert front[0] - rear_left[0] == pytest.approx(WHEELBASE)
    assert rear_left[1] - rear_right[1] == pytest.approx(TRACK)
    wheel = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "rear_left_wheel")
    assert model.geom_size[wheel][0] == pytest.approx(WHEEL_RADIUS)
    assert 2 * model.geom_size[wheel][1] == pytest.approx(WHEEL_WIDTH)


def test_missing_model_is_reported() -> None:
    with pytest.raises(mcs.MulticosimError, match="could not load"):
        Physics.from_xml_path("/nonexistent/rover.xml", WorldConfig())


# -- the world participant ------------------------------------------------------------------


class Recorder:
    """Records every sensor message of the rover."""

    period = 0.01

    def __init__(self, topics: dict[str, str] | None = None) -> None:
        self.topics = topics or SENSOR_TOPICS
        self.log: dict[str, list[Any]] = {}

    def setup(self, ctx: mcs.StepContext) -> None:
        types: dict[str, type[Any]] = {
            "position": Position,
            "magnetometer": MagneticField,
            "imu": Imu,
            "wheel_speed": WheelSpeed,
        }
        self.subs: dict[str, mcs.Subscription[Any]] = {
            name: ctx.subscribe(topic, types[name]) for name, topic in self.topics.items()
        }

    def step(self, ctx: mcs.StepContext) -> None:
        for name, sub in self.subs.items():
            self.log.setdefault(name, []).extend(sub.messages)


@dataclasses.dataclass
class Commander:
    """Publishes a fixed command every period."""

    command: Command
    period: float = 0.05

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        ctx.publish(COMMAND_TOPIC, self.command)


def _run(
    command: Command, duration: float, config: RoverWorldConfig | None = None, seed: int = 0
) -> Recorder:
    recorder = Recorder(
        {n: (config or RoverWorldConfig()).world.topic(n, t) for n, t in SENSOR_TOPICS.items()}
    )
    simulator = mcs.ProcessSimulator(seed=seed)
    simulator.add(mcs.InProcessComponent(lambda: rover_world(config), name="world"))
    simulator.add(mcs.InProcessComponent(lambda: Commander(command), name="commander"))
    simulator.add(mcs.InProcessComponent(lambda: recorder, name="recorder"))
    with simulator.start() as simulation:
        simulation.advance(duration)
    return recorder


def test_world_at_rest_publishes_stamped_sensors() -> None:
    log = _run(Command(speed=0.0, steering=0.0), 0.5).log
    positions = log["position"]
    # One reading per period, stamped with the simulated time of the state it describes.
    assert [p.time for p in positions] == pytest.approx([i * 0.01 for i in range(50)])
    last = positions[-1]
    assert (last.x, last.y, last.z) == pytest.approx((0.0, 0.0, 0.25), abs=2e-3)
    assert (last.latitude, last.longitude) == pytest.approx(DEFAULT_HOME[:2], abs=1e-7)
    assert last.altitude == pytest.approx(DEFAULT_HOME[2] + 0.25, abs=2e-3)
    field = log["magnetometer"][-1]
    assert heading_from_field(field.x, field.y) == pytest.approx(0.0, abs=1e-3)
    imu = log["imu"][-1]
    assert imu.acceleration[2] == pytest.approx(9.81, abs=0.05)
    assert imu.orientation == pytest.approx((1.0, 0.0, 0.0, 0.0), abs=1e-3)
    assert log["wheel_speed"][-1].speed == pytest.approx(0.0, abs=1e-3)


def test_world_drives_straight_and_turns_left() -> None:
    straight = _run(Command(speed=2.0, steering=0.0), 3.0).log
    end = straight["position"][-1]
    assert 3.0 < end.x < 6.0
    assert end.y == pytest.approx(0.0, abs=0.05)
    assert straight["wheel_speed"][-1].speed == pytest.approx(2.0, abs=0.05)

    turning = _run(Command(speed=2.0, steering=0.4), 3.0).log
    field = turning["magnetometer"][-1]
    assert heading_from_field(field.x, field.y) > 0.5  # counter-clockwise = left
    assert turning["imu"][-1].angular_velocity[2] > 0.3
    assert turning["position"][-1].y > 0.5


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("solver", SOLVERS)
def test_every_integrator_and_solver_drive_the_rover(integrator: str, solver: str) -> None:
    config = RoverWorldConfig(
        world=WorldConfig(integrator=integrator, solver=solver)  # type: ignore[arg-type]
    )
    end = _run(Command(speed=2.0, steering=0.0), 2.0, config).log["position"][-1]
    assert 1.0 < end.x < 4.0
    assert abs(end.y) < 0.1
    assert end.z == pytest.approx(0.25, abs=0.01)


def test_sensor_topics_are_remapped() -> None:
    config = RoverWorldConfig(world=WorldConfig(sensor_topics={"magnetometer": "raw/compass"}))
    world = rover_world(config)
    assert world.topics["magnetometer"] == "raw/compass"
    assert world.topics["position"] == SENSOR_TOPICS["position"]
    log = _run(Command(speed=0.0, steering=0.0), 0.1, config).log
    assert len(log["magnetometer"]) == 10  # received on the remapped topic


def test_noise_is_seeded() -> None:
    from multicosim.rover import SensorNoise

    config = RoverWorldConfig(noise=SensorNoise.realistic())
    a = _run(Command(speed=0.0, steering=0.0), 0.2, config, seed=1).log["position"]
    b = _run(Command(speed=0.0, steering=0.0), 0.2, config, seed=1).log["position"]
    c = _run(Command(speed=0.0, steering=0.0), 0.2, config, seed=2).log["position"]
    assert a == b
    assert a != c


def test_world_runs_as_a_process(no_leaks: None) -> None:
    config = RoverWorldConfig(world=WorldConfig(sensor_topics={"imu": "raw/imu"}))
    recorder = Recorder({"position": SENSOR_TOPICS["position"], "imu": "raw/imu"})
    simulator = mcs.ProcessSimulator(seed=0)
    from multicosim.local import config_json

    simulator.add(
        mcs.ProcessComponent(
            [
                "python",
                "-m",
                "multicosim",
                "participant",
                "multicosim.rover.body:rover_world",
                "--config",
                config_json(config),
            ],
            name="world",
        )
    )
    simulator.add(
        mcs.InProcessComponent(
            lambda: Commander(Command(speed=1.5, steering=0.0)), name="commander"
        )
    )
    simulator.add(mcs.InProcessComponent(lambda: recorder, name="recorder"))
    with simulator.start() as simulation:
        simulation.advance(2.0)
    positions = recorder.log["position"]
    assert positions[-1].time == pytest.approx(1.99)
    assert positions[-1].x > 1.0
    assert len(recorder.log["imu"]) == len(positions)


def test_world_is_a_participant() -> None:
    world = rover_world()
    assert isinstance(world, World)
    assert isinstance(world, mcs.Participant)
    assert world.period == WorldConfig().period


def test_core_and_rover_do_not_import_mujoco() -> None:
    code = (
        "import sys, multicosim, multicosim.rover, multicosim.physics\n"
        "multicosim.physics.WorldConfig(timestep=0.001)\n"
        "assert 'mujoco' not in sys.modules, 'mujoco imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_mujoco_raises_dependency_missing() -> None:
    code = (
        "import sys\n"
        "sys.modules['mujoco'] = None\n"
        "import multicosim, multicosim.physics\n"
        "try:\n"
        "    multicosim.physics.World\n"
        "except multicosim.DependencyMissingError as exc:\n"
        "    assert exc.extra == 'mujoco', exc\n"
        "    print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert out.stdout.strip() == "ok"


def test_divergence_is_an_error_not_a_silent_reset() -> None:
    from multicosim.physics import PhysicsDivergedError
    from multicosim.rover import ackermann

    config = WorldConfig(timestep=0.05, integrator="Euler", period=0.05)
    physics = Physics.from_xml_path(RoverVehicle.model_path, config)
    physics.data.ctrl[:] = ackermann(5.0, 0.5)
    with pytest.raises(PhysicsDivergedError, match=r"diverged .*timestep=0\.05"):
        physics.step_to(5.0)


def test_diverging_world_process_is_reported_with_its_reason(no_leaks: None) -> None:
    import multicosim.rover as rover

    world = WorldConfig(timestep=0.05, integrator="Euler", period=0.05)
    with (
        rover.Rover(fidelity="medium", world=world).start() as simulation,
        pytest.raises(mcs.NodeCrashedError) as info,
    ):
        simulation.controller.send(rover.Mission(speed=5.0, wait=0.0))
    assert info.value.name == "world"
    assert "diverged" in info.value.log_tail
