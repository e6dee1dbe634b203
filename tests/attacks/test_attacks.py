"""The sensor injector: models, sensors, bad input, strategies, and the gps_noise fixture."""

from __future__ import annotations

import math
import statistics
from typing import Any

import msgspec
import pytest
from hypothesis import given, settings

import multicosim as mcs
import multicosim.attacks as attacks
import multicosim.px4 as px4
import multicosim.rover as rover
from multicosim.attacks import strategies as ast
from multicosim.attacks.models import broadcast, check_models
from multicosim.core.geo import LocalProjection
from multicosim.px4 import hil
from multicosim.rover import MagneticField, Position

PERIOD = 0.1


class Source:
    """Publishes a fixed rover position every period."""

    period = PERIOD

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        position = Position(
            time=ctx.time, x=1.0, y=2.0, z=0.25, latitude=47.0, longitude=8.0, altitude=488.25
        )
        ctx.publish("raw", position)


class Sink:
    """Keeps what arrives on the firmware's topic, with the time it arrived."""

    def __call__(self) -> Sink:
        """Itself: a factory for InProcessComponent that hands out this very sink."""
        return self

    period = PERIOD

    def __init__(self, tp: type[Any] = Position) -> None:
        self.type = tp
        self.received: list[tuple[float, Any]] = []

    def setup(self, ctx: mcs.StepContext) -> None:
        self.sub = ctx.subscribe("firmware", self.type)

    def step(self, ctx: mcs.StepContext) -> None:
        self.received.extend((round(ctx.time, 9), m) for m in self.sub.messages)


class Environment:
    """Another component computing an offset: publishes ``value(t)`` on ``env`` from 0.3 s."""

    period = PERIOD

    def __init__(self, value: Any) -> None:
        self.value = value

    def setup(self, ctx: mcs.StepContext) -> None:
        pass

    def step(self, ctx: mcs.StepContext) -> None:
        if ctx.time >= 0.3 - 1e-9:
            ctx.publish("env", self.value(ctx.time))


def run(
    models: list[attacks.Model],
    duration: float = 2.0,
    seed: int = 0,
    beside: Any = None,
    placement: str = "in-process",
) -> list[Any]:
    """The rover positions the sink received through an injector with ``models``
    (``beside``: a participant factory added before the injector)."""
    sink = Sink()
    simulator = mcs.ProcessSimulator(seed=seed)
    simulator.add(mcs.InProcessComponent(Source, name="source"))
    if beside is not None:
        simulator.add(mcs.InProcessComponent(beside, name="beside"))
    config = attacks.InjectorConfig(
        vehicle="rover",
        sensor="gps",
        source="raw",
        target="firmware",
        period=PERIOD,
        models=tuple(models),
    )
    simulator.add(attacks.InjectorComponent(config, placement=placement))
    simulator.add(mcs.InProcessComponent(sink, name="sink"))
    with simulator.start() as simulation:
        simulation.advance(duration)
    return sink.received


@pytest.mark.parametrize("placement", ["in-process", "process"])
def test_a_stream_adds_what_another_component_publishes(placement: str) -> None:
    models: list[attacks.Model] = [attacks.Stream(topic="env", scale=2.0, end=1.5)]
    received = dict(
        run(models, beside=lambda: Environment(lambda t: [t, -t, 0.0]), placement=placement)
    )
    assert (received[0.2].x, received[0.2].y) == (1.0, 2.0)  # nothing published yet
    assert received[0.5].x == pytest.approx(1.0 + 2 * 0.5)  # published in the same instant
    assert received[0.5].y == pytest.approx(2.0 - 2 * 0.5)
    assert received[1.6].x == 1.0  # the window closed
    # One number is the same on every axis.
    received = dict(run([attacks.Stream(topic="env")], beside=lambda: Environment(lambda t: 0.5)))
    assert (received[0.4].x, received[0.4].y, received[0.4].z) == (1.5, 2.5, 0.75)


def test_a_stream_of_the_wrong_size_names_its_topic() -> None:
    with pytest.raises(mcs.ConfigurationError, match="the value on 'env'"):
        run([attacks.Stream(topic="env")], beside=lambda: Environment(lambda t: [1.0, 2.0]))


def test_zero_models_pass_the_same_objects_in_the_same_instant() -> None:
    received = run([attacks.Gaussian(std=0.0), attacks.Bias(), attacks.Delay(delay=0.0)])
    assert [t for t, _ in received] == [round(i * PERIOD, 9) for i in range(len(received))]
    assert all(m.time == t for t, m in received)
    assert attacks.is_zero(attacks.Gaussian(std=0.0))
    assert attacks.is_zero(attacks.Jump(offset=(0.0, 0.0, 0.0), ramp=2.0))
    assert not attacks.is_zero(attacks.Dropout(start=1.0, end=2.0))


def test_gaussian_noise_has_its_mean_and_deviation() -> None:
    received = run(
        [attacks.Gaussian(std=attacks.Local(east=0.5, north=2.0), mean=attacks.Local(east=1.0))],
        duration=60.0,
    )
    dx = [m.x - 1.0 for _, m in received]
    dy = [m.y - 2.0 for _, m in received]
    assert statistics.mean(dx) == pytest.approx(1.0, abs=0.1)
    assert statistics.stdev(dx) == pytest.approx(0.5, rel=0.15)
    assert statistics.stdev(dy) == pytest.approx(2.0, rel=0.15)
    assert all(m.z == 0.25 for _, m in received)  # zero deviation on that axis
    # Latitude moves with north and altitude with up, consistently.
    north = [(m.latitude - 47.0) * math.pi / 180 * 6_371_000 for _, m in received]
    assert north == pytest.approx(dy, abs=1e-6)


def test_bias_drift_and_jump_combine_with_their_windows() -> None:
    received = dict(
        run(
            [
                attacks.Bias(offset=attacks.Local(east=0.5), start=0.5, end=1.0),
                attacks.Jump(offset=attacks.Local(north=4.0), start=1.0, ramp=0.4),
                attacks.Drift(rate=attacks.Local(up=1.0), start=1.5),
            ]
        )
    )
    assert received[0.4].x == 1.0
    assert received[0.5].x == 1.5
    assert received[1.0].x == 1.0  # the bias ended; the jump starts from zero
    assert received[1.2].y == pytest.approx(2.0 + 2.0)  # half-way up the ramp
    assert received[1.4].y == pytest.approx(6.0)
    assert received[1.9].y == pytest.approx(6.0)
    assert received[1.5].z == pytest.approx(0.25)  # the walk starts at zero
    assert received[1.9].z == pytest.approx(0.25 + 0.4)  # 1 m/s for 0.4 s


def test_random_walk_spreads_with_the_square_root_of_time() -> None:
    ends = [run([attacks.Drift(std=1.0)], duration=4.0, seed=s)[-1][1].x - 1.0 for s in range(60)]
    # After ~3.9 s the walk's deviation is sqrt(3.9) m.
    assert statistics.stdev(ends) == pytest.approx(math.sqrt(3.9), rel=0.3)


def test_dropout_and_delay_hold_readings_back_in_order() -> None:
    received = run([attacks.Dropout(start=0.3, end=0.6), attacks.Delay(delay=0.2, start=1.0)])
    times = [m.time for _, m in received]
    assert not [t for t in times if 0.3 <= t < 0.6 - 1e-9]
    late = [(arrival, m.time) for arrival, m in received if m.time >= 1.0 - 1e-9]
    assert late
    assert all(arrival == pytest.approx(sent + 0.2) for arrival, sent in late)
    assert times == sorted(times)


def test_same_seed_same_corruption_other_seed_other() -> None:
    models: list[attacks.Model] = [attacks.Gaussian(std=1.0), attacks.Drift(std=0.5)]
    assert run(models, seed=3) == run(models, seed=3)
    assert run(models, seed=3) != run(models, seed=4)


def test_injector_runs_the_same_as_a_process() -> None:
    models: list[attacks.Model] = [attacks.Gaussian(std=1.0), attacks.Jump(offset=2.0, start=1)]
    config = attacks.InjectorConfig(
        vehicle="rover",
        sensor="gps",
        source="raw",
        target="firmware",
        period=PERIOD,
        models=tuple(models),
    )
    results = []
    for placement in ("in-process", "process"):
        sink = Sink()
        simulator = mcs.ProcessSimulator(seed=5)
        simulator.add(mcs.InProcessComponent(Source, name="source"))
        simulator.add(attacks.InjectorComponent(config, placement=placement))
        simulator.add(mcs.InProcessComponent(sink, "sink"))
        with simulator.start() as simulation:
            simulation.advance(2.0)
        results.append(sink.received)
    assert results[0] == results[1]
    assert (
        msgspec.json.decode(
            attacks.InjectorComponent(config).command[-1], type=attacks.InjectorConfig
        )
        == config
    )


# -- sensors --------------------------------------------------------------------------------


@pytest.mark.parametrize("vehicle", ["rover", "px4"])
def test_heading_offset_turns_the_heading_the_firmware_computes(vehicle: str) -> None:
    spec = attacks.sensor(vehicle, "compass")
    yaw = 0.3
    if vehicle == "rover":
        msg: Any = MagneticField(time=0.0, x=math.sin(yaw) * 2e-5, y=math.cos(yaw) * 2e-5, z=-4e-5)
        moved = spec.apply(msg, "heading", [0.2])
        assert rover.heading_from_field(moved.x, moved.y) == pytest.approx(yaw + 0.2)
    else:
        mn, me = 0.21, 0.015
        c, s = math.cos(yaw), math.sin(yaw)
        zero = (0.0, 0.0, 0.0)
        msg = hil.HilSensor(
            1, *zero, *zero, c * mn + s * me, -s * mn + c * me, 0.43, *zero, 0.0, 0x1C0
        )
        moved = spec.apply(msg, "heading", [0.2])

        # The estimator's heading: the body field rotated back to the level NED frame.
        def heading(m: Any, psi: float) -> float:
            n = math.cos(psi) * m.xmag - math.sin(psi) * m.ymag
            e = math.sin(psi) * m.xmag + math.cos(psi) * m.ymag
            return math.atan2(e, n)

        assert heading(moved, yaw + 0.2) == pytest.approx(heading(msg, yaw), abs=1e-12)


def test_px4_gps_offsets_survive_the_mavlink_wire() -> None:
    proj = LocalProjection(47.397742, 8.545594)
    gps = hil.HilGps(1000, 3, 473977420, 85455940, 488000, 70, 100, 0, 0, 0, 0, 0, 12)
    spec = attacks.sensor("px4", "gps")
    packet = spec.write(gps, "mavlink")
    moved = spec.apply(spec.read(packet), "position", [3.0, -10.0, 1.5])
    back = spec.read(spec.write(moved, "mavlink"))
    north, east = proj.project(back.lat * 1e-7, back.lon * 1e-7)
    assert (north, east) == pytest.approx((-10.0, 3.0), abs=0.02)  # degE7 is ~1 cm
    assert back.alt == 489500
    faster = spec.apply(back, "velocity", [0.0, 2.0, 0.0])
    assert (faster.vn, faster.ve, faster.vel, faster.cog) == (200, 0, 200, 0)


# -- bad input ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: attacks.Gaussian(std=-1.0), "std"),
        (lambda: attacks.Gaussian(std=(1.0, -0.1, 0.0)), "std"),
        (lambda: attacks.Jump(offset=1.0, start=5.0, end=4.0), "end"),
        (lambda: attacks.Bias(offset=1.0, start=-1.0), "start"),
        (lambda: attacks.Jump(offset=1.0, ramp=-2.0), "ramp"),
        (lambda: attacks.Delay(delay=math.nan), "delay"),
        (lambda: attacks.Drift(std=float("inf")), "std"),
        (lambda: attacks.Stream(topic=""), "topic"),
        (lambda: attacks.Stream(topic="env", scale=math.inf), "scale"),
    ],
)
def test_bad_model_values_name_the_field(build: Any, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        build()
    assert info.value.field == field


def _config(**changes: Any) -> attacks.InjectorConfig:
    base: dict[str, Any] = {
        "vehicle": "rover",
        "sensor": "gps",
        "source": "raw",
        "target": "firmware",
        "period": 0.1,
    }
    return attacks.InjectorConfig(**{**base, **changes})


def test_a_position_offset_is_given_by_name_and_a_tuple_is_deprecated() -> None:
    by_name = _config(models=(attacks.Jump(offset=attacks.Local(north=4.0, up=-1.0)),))
    with pytest.warns(DeprecationWarning, match=r"order \('east', 'north', 'up'\)"):
        by_order = _config(models=(attacks.Jump(offset=(0.0, 4.0, -1.0)),))
    # The same reading either way: 4 m north, 1 m down (the rover's x/y/z are east/north/up).
    received = dict(run(list(by_name.models)))
    assert (received[0.2].x, received[0.2].y, received[0.2].z) == (1.0, 6.0, -0.75)
    with pytest.warns(DeprecationWarning, match="attacks.Local"):
        assert dict(run(list(by_order.models))) == received
    # A Local travels to an injector process as it is.
    again = msgspec.json.decode(msgspec.json.encode(by_name), type=attacks.InjectorConfig)
    assert again == by_name
    with pytest.raises(mcs.ConfigurationError, match="north"):
        attacks.Local(north=math.inf)


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"sensor": "lidar"}, "sensor"),
        ({"vehicle": "boat"}, "vehicle"),
        ({"target": "raw"}, "target"),
        ({"source": ""}, "source"),
        ({"period": 0.0}, "period"),
        ({"wire": "mavlink"}, "wire"),
        ({"models": (attacks.Jump(offset=1.0, on="velocity"),)}, "models[0].on"),
        ({"models": (attacks.Bias(offset=1.0), attacks.Bias(on="heading"))}, "models[1].on"),
        ({"models": (attacks.Bias(offset=(1.0, 2.0)),)}, "models[0].offset"),
        ({"models": ("noise",)}, "models[0]"),
        (
            {"sensor": "magnetometer", "models": (attacks.Jump(offset=(0.1, 0.0, 0.0)),)},
            "models[0].offset",
        ),
        (  # a body field has no north: names keep a wrong frame from passing silently
            {
                "sensor": "magnetometer",
                "models": (attacks.Bias(offset=attacks.Local(north=1e-6), on="field"),),
            },
            "models[0].offset",
        ),
    ],
)
def test_bad_injector_configurations_fail_before_start(changes: Any, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        _config(**changes)
    assert info.value.field == field
    assert info.value.allowed


def test_inject_refuses_what_does_not_fit_before_changing_anything() -> None:
    simulator = rover.Rover(fidelity="low")
    with pytest.raises(mcs.ConfigurationError, match="sensor='sonar'"):
        attacks.inject(simulator, "sonar", [])
    with pytest.raises(mcs.ConfigurationError, match=r"models\[0\]\.on"):
        attacks.inject(simulator, "gps", [attacks.Gaussian(on="heading")])
    assert simulator.config.world.sensor_topics == {}
    attacks.inject(simulator, "gps", [attacks.Gaussian(std=1.0)])
    with pytest.raises(mcs.ConfigurationError, match="without an injector"):
        attacks.inject(simulator, "position", [])
    with pytest.raises(mcs.ConfigurationError, match="simulator"):
        attacks.inject(object(), "gps", [])
    px4_sim = px4.PX4(fidelity="low")
    attacks.inject(px4_sim, "gps", [])
    assert px4_sim.autopilot_topics.gps == "px4/gps/attacked"
    with pytest.raises(mcs.ConfigurationError, match="without an injector"):
        attacks.inject(px4_sim, "position", [])


def test_inject_after_start_says_how_to_fix_it() -> None:
    simulator = rover.Rover(fidelity="low")
    with simulator.start(), pytest.raises(mcs.MulticosimError) as info:
        attacks.inject(simulator, "gps", [])
    assert any("*_simulator fixture" in note for note in info.value.__notes__)


# -- strategies -----------------------------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(ast.attacks("px4", "gps", max_models=4, magnitude=(0.0, 5.0)))
def test_generated_attacks_are_valid_for_their_sensor(models: list[attacks.Model]) -> None:
    config = attacks.InjectorConfig(
        vehicle="px4", sensor="gps", source="a", target="b", period=0.1, models=tuple(models)
    )
    assert msgspec.json.decode(msgspec.json.encode(config), type=attacks.InjectorConfig) == config


@settings(max_examples=30, deadline=None)
@given(ast.jumps((2.0, 3.0), axes=3, start=(1.0, 2.0), ramp=(0.0, 1.0)))
def test_generated_jumps_respect_their_bounds(jump: attacks.Jump) -> None:
    assert isinstance(jump.offset, tuple)
    assert 2.0 - 1e-9 <= math.hypot(*jump.offset) <= 3.0 + 1e-9
    assert 1.0 <= jump.start <= 2.0
    assert 0.0 <= jump.ramp <= 1.0


def test_strategies_shrink_to_no_attack() -> None:
    from hypothesis import find

    assert find(ast.attacks("rover", "gps"), lambda _: True) == []
    assert find(ast.gaussians((0.0, 3.0)), lambda _: True).std == 0.0


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: ast.gaussians((2.0, 1.0)), "std"),
        (lambda: ast.jumps((0.0, 1.0), start=(-1.0, 1.0)), "start"),
        (lambda: ast.attacks("px4", "gps", kinds=["laser"]), "kinds"),
        (lambda: ast.attacks("px4", "sonar"), "sensor"),
        (lambda: ast.offsets((0.0, 1.0), axes=0), "axes"),
    ],
)
def test_bad_strategy_bounds_name_the_argument(build: Any, field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        build()
    assert info.value.field == field


# -- the fixture ----------------------------------------------------------------------------


def test_gps_noise_fixture_needs_one_scenario_simulator(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        import pytest
        import multicosim as mcs
        import multicosim.attacks as attacks

        def test_neither(gps_noise):
            with pytest.raises(mcs.ConfigurationError, match="exactly one"):
                gps_noise(std=1.0)

        def test_started(rover_simulation, rover_simulator, gps_noise):
            with pytest.raises(mcs.MulticosimError, match="after start"):
                gps_noise(std=1.0)

        def test_rover(rover_simulator, gps_noise):
            injector = gps_noise(
                std=1.0, spoof=attacks.Local(east=1.0), start=2.0, end=5.0, delay=0.1
            )
            assert [type(m).__name__ for m in injector.config.models] == [
                "Gaussian", "Jump", "Delay"
            ]
            assert rover_simulator.config.world.sensor_topics == {
                "position": "rover/position/raw"
            }
        """
    )
    result = pytester.runpytest("-p", "no:cacheprovider", "--mcs-fidelity=low")
    result.assert_outcomes(passed=3)


# -- traces of attacked scenarios -----------------------------------------------------------


@pytest.mark.parametrize("fidelity", ["low", "medium"])
def test_rover_trace_shows_truth_and_sensed_track(tmp_path: Any, fidelity: str) -> None:
    from multicosim.trace import Recorder, read_trace

    simulator = rover.Rover(fidelity=fidelity)  # type: ignore[arg-type]
    attacks.inject(simulator, "gps", [attacks.Jump(offset=attacks.Local(north=3.0), start=1.0)])
    with simulator.start() as simulation, Recorder().attach(simulation) as recorder:
        simulation.controller.send(rover.Mission(speed=2.0, wait=0.5, distance=2.0))
    trace = read_trace(recorder.save(tmp_path / "rover.mcap", fidelity=fidelity))
    assert {"rover/position", "rover/position/raw", "mcs/location", "mcs/pose"} <= set(
        trace.channels
    )
    assert trace.channels["rover/position/raw"].schema_name.endswith("Position")
    assert trace.channels["mcs/location/sensed"].schema_name == "foxglove.LocationFix"
    truth, sensed = trace.topic("mcs/location")[-1].data, trace.topic("mcs/location/sensed")[-1]
    north = (sensed.data["latitude"] - truth["latitude"]) * math.pi / 180 * 6_371_000
    assert north == pytest.approx(3.0, abs=0.1)  # the spoof, between the two tracks
    pose = trace.topic("mcs/pose")[-1].data["pose"]
    assert set(pose) == {"position", "orientation"}


def test_px4_trace_shows_truth_and_estimate_on_the_map(tmp_path: Any) -> None:
    from multicosim.trace import Recorder, read_trace

    proj = LocalProjection(px4.Home().lat, px4.Home().lon)
    lat, lon = proj.reproject(0.0, 20.0)
    with px4.PX4(fidelity="low").start() as simulation, Recorder().attach(simulation) as rec:
        simulation.firmware.send(px4.Configuration([px4.Waypoint(lat, lon, 8.0)], end="hold"))
    trace = read_trace(rec.save(tmp_path / "px4.mcap"))
    for track in ("px4/location/truth", "px4/location/estimate"):
        fix = trace.topic(track)[-1].data
        north_east = proj.project(fix["latitude"], fix["longitude"])
        assert north_east == pytest.approx((0.0, 20.0), abs=2.5)
        assert fix["altitude"] == pytest.approx(px4.Home().alt + 8.0, abs=1.0)
    # The pose is the autopilot's: its estimated position, east-north-up.
    position = trace.topic("px4/pose")[-1].data["pose"]["position"]
    assert (position["x"], position["y"], position["z"]) == pytest.approx((20.0, 0.0, 8.0), abs=2.5)


def test_simulator_places_and_replaces_components_before_start() -> None:
    simulator = mcs.ProcessSimulator()
    first = simulator.add(mcs.InProcessComponent(Source, name="source"))
    last = simulator.add(mcs.InProcessComponent(Sink(), name="sink"))
    middle = simulator.add(mcs.InProcessComponent(Sink(), name="middle"), before=last)
    assert [nid for nid, _ in simulator._components] == [first, middle, last]
    other = mcs.ProcessSimulator()
    with pytest.raises(mcs.ConfigurationError, match="node_id"):
        other.add(mcs.InProcessComponent(Source, name="x"), before=last)
    sink = Sink()
    simulator.replace(last, mcs.InProcessComponent(sink, name="sink"))
    with simulator.start() as simulation:
        assert simulation.get(last).participant is sink
        with pytest.raises(mcs.MulticosimError, match="after start"):
            simulator.replace(last, mcs.InProcessComponent(Sink(), name="sink"))


class _Depth(msgspec.Struct, frozen=True):
    time: float
    depth: float


def _deeper(msg: Any, quantity: str, delta: Any) -> Any:
    return msgspec.structs.replace(msg, depth=msg.depth + delta[0])


def test_a_vehicle_of_ones_own_registers_its_sensors() -> None:
    depth = attacks.Sensor(
        "boat", "sonar", _Depth, {"depth": attacks.Quantity(("d",), "m")}, _deeper
    )
    attacks.register("boat", [depth], {"depth": "sonar"}, module="boats.sensors")
    assert "boat" in attacks.vehicles()
    assert attacks.sensor("boat", "depth") is depth  # by its alias
    config = attacks.InjectorConfig(
        vehicle="boat",
        sensor="sonar",
        source="boat/sonar/raw",
        target="boat/sonar",
        period=0.1,
        models=(attacks.Bias(offset=(2.0,)),),
    )
    # An injector in another process imports the module that registers the boat's sensors.
    assert config.module == "boats.sensors"
    moved = depth.apply(_Depth(time=0.0, depth=5.0), "depth", (2.0,))
    assert moved.depth == 7.0
    with pytest.raises(mcs.ConfigurationError, match="registered sensors"):
        attacks.sensor("submarine", "sonar")


def test_a_local_offset_fits_a_quantity_of_fewer_axes_by_name() -> None:
    # A user's two-axis position: Local's north and east go to its axes by name; up, which
    # it lacks, must not be given.
    quantities = {"position": ("north", "east")}
    (bias,) = check_models(
        (attacks.Bias(offset=attacks.Local(east=2.0)),), quantities, "position", "boat"
    )
    assert isinstance(bias, attacks.Bias)
    (offset,) = bias.vectors().values()
    assert broadcast("offset", offset, ("north", "east"), "position") == (0.0, 2.0)
    with pytest.raises(mcs.ConfigurationError) as info:
        check_models(
            (attacks.Bias(offset=attacks.Local(north=1.0, up=3.0)),),
            quantities,
            "position",
            "boat",
        )
    assert "Local(north=1, up=3)" in str(info.value)
    assert "('north', 'east')" in str(info.value)
    # Axes a Local does not name cannot be given by it.
    with pytest.raises(mcs.ConfigurationError, match="depth"):
        check_models(
            (attacks.Bias(offset=attacks.Local(north=1.0)),), {"depth": ("d",)}, "depth", "boat"
        )
