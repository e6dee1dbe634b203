"""The paper's mission API end to end at low fidelity (fast), plus bad input and attacks."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.hil import HilGps, MavlinkPacket
from multicosim.px4 import strategies as px4st

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


def test_listing_1_of_the_paper() -> None:
    world = px4.WorldConfig()
    simulator = px4.PX4(world, fidelity="low")
    simulation = simulator.start()
    try:
        mission = [px4.Waypoint(lat=47.3980, lon=8.5460, alt=25.0)]
        result = simulation.firmware.send(px4.Configuration(mission))
    finally:
        simulation.stop()
    simulation.stop()  # idempotent
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == [0]
    assert result.landed
    assert not result.armed
    assert {"AUTO.LOITER", "AUTO.MISSION"} <= {s.mode for s in result.trajectory}
    assert "Mission finished" in result.messages


def test_same_seed_same_trajectory() -> None:
    config = px4.Configuration([wp(30, 30, 12), wp(-20, 10, 8)], end="rtl")

    def fly(seed: int) -> px4.MissionResult:
        with px4.PX4(fidelity="low", seed=seed).start() as sim:
            return sim.firmware.send(config)

    first, second = fly(3), fly(3)
    assert first == second
    assert first.completed


def test_wrong_message_type_is_refused() -> None:
    with px4.PX4(fidelity="low").start() as sim, pytest.raises(mcs.MessageTypeError):
        sim.firmware.send([px4.Waypoint(47.398, 8.546, 10.0)])  # type: ignore[arg-type]


def test_waypoint_beyond_geofence_is_refused_before_flying() -> None:
    with px4.PX4(fidelity="low", geofence=px4.Geofence(radius=100.0)).start() as sim:
        with pytest.raises(mcs.ConfigurationError) as info:
            sim.firmware.send(px4.Configuration([wp(50, 0, 10), wp(150, 0, 10)]))
        assert info.value.field == "mission[1]"
        assert sim.time == 0.0  # nothing flew


def test_arming_refused_without_gps_fix() -> None:
    # The autopilot reads GPS from a topic nobody publishes: no fix, ever.
    simulator = px4.PX4(fidelity="low", autopilot_topics=px4.Topics(gps="px4/gps/nowhere"))
    with simulator.start() as sim:
        result = sim.firmware.send(px4.Configuration([wp(20, 0, 10)], time_limit=120.0))
    assert not result.completed
    assert result.reason.startswith("arming refused")
    assert "GPS" in result.reason
    assert not result.armed
    assert not result.reached


def test_time_limit_before_arming_names_what_the_autopilot_lacks() -> None:
    # No GPS fix ever: the pre-arm checks never pass, and the time limit runs out first.
    simulator = px4.PX4(fidelity="low", autopilot_topics=px4.Topics(gps="px4/gps/nowhere"))
    with simulator.start() as sim:
        result = sim.firmware.send(px4.Configuration([wp(20, 0, 10)], time_limit=5.0))
    assert not result.completed
    assert result.reason == (
        "time limit of 5 s reached before arming: its pre-arm checks do not pass"
    )
    assert result.end_time - result.start_time == pytest.approx(5.0, abs=0.1)
    assert not result.armed


class GpsCut:
    """Forwards GPS until ``after`` seconds, then drops it (a jammer)."""

    period = 0.1

    def __init__(self, after: float) -> None:
        self.after = after

    def setup(self, ctx: Any) -> None:
        self.sub = ctx.subscribe("px4/gps", HilGps)

    def step(self, ctx: Any) -> None:
        for msg in self.sub.messages:
            if ctx.time < self.after:
                ctx.publish("px4/gps/in", msg)


class GpsShift:
    """Moves every GPS fix ``offset`` metres north after ``after`` seconds (spoofing)."""

    period = 0.1

    def __init__(self, after: float, offset: float) -> None:
        self.after, self.offset = after, offset

    def setup(self, ctx: Any) -> None:
        self.sub = ctx.subscribe("px4/gps", HilGps)

    def step(self, ctx: Any) -> None:
        import msgspec

        for msg in self.sub.messages:
            if ctx.time >= self.after:
                msg = msgspec.structs.replace(msg, lat=msg.lat + round(self.offset / 111_195 * 1e7))
            ctx.publish("px4/gps/in", msg)


def _with_injector(injector: Any) -> px4.PX4:
    simulator = px4.PX4(fidelity="low", autopilot_topics=px4.Topics(gps="px4/gps/in"))
    simulator.add(mcs.InProcessComponent(lambda: injector, "injector"))
    return simulator


def test_gps_loss_triggers_the_landing_failsafe() -> None:
    with _with_injector(GpsCut(after=20.0)).start() as sim:
        result = sim.firmware.send(px4.Configuration([wp(200, 0, 20)], time_limit=200.0))
    assert not result.completed
    assert "GPS lost" in result.reason
    assert result.landed
    assert not result.armed
    assert any(s.mode == "AUTO.LAND" for s in result.trajectory)
    assert min(s.true_alt for s in result.trajectory) > -0.3


def test_spoofed_gps_misleads_the_estimator() -> None:
    with _with_injector(GpsShift(after=8.0, offset=25.0)).start() as sim:
        result = sim.firmware.send(px4.Configuration([wp(0, 40, 10)], end="hold"))
    assert result.completed, result.reason
    last = result.trajectory[-1]
    est_n, _ = PROJ.project(last.lat, last.lon)
    true_n, _ = PROJ.project(last.true_lat, last.true_lon)
    # The autopilot believes it is at the waypoint; in truth it is ~25 m south of it.
    assert abs(est_n) < 3.0
    assert true_n == pytest.approx(-25.0, abs=3.0)


@pytest.mark.parametrize(
    ("height_ref", "descends"),
    [(None, False), (1, False), (0, True)],
    ids=["default", "gnss", "baro"],
)
def test_the_height_reference_follows_ekf2_hgt_ref(height_ref: int | None, descends: bool) -> None:
    import multicosim.attacks as attacks

    # A barometer reading 8 m high from 12 s on: PX4's default takes height from GNSS and
    # only tracks the barometer's offset; with EKF2_HGT_REF 0 the barometer is the height.
    params = {} if height_ref is None else {"EKF2_HGT_REF": float(height_ref)}
    simulator = px4.PX4(fidelity="low", params=params)
    attacks.inject(simulator, "baro", [attacks.Jump(offset=8.0, start=12.0, ramp=4.0)])
    with simulator.start() as sim:
        result = sim.firmware.send(px4.Configuration([wp(0, 40, 10), wp(40, 40, 10)], end="hold"))
    cruising = [s.true_alt for s in result.trajectory if s.current >= 1]
    if descends:
        # It believes the barometer: down by the spoof, onto the ground.
        assert min(cruising) < 3.0
    else:
        assert min(cruising) > 9.0
        assert max(abs(s.alt - s.true_alt) for s in result.trajectory) < 0.5


def test_sensor_topics_carry_mavlink_frames_at_medium_wire() -> None:
    from multicosim.mavlink.hil import HilSensor, Packer, read, unpack

    msg = HilSensor(1, 0.1, 0.2, -9.8, 0.0, 0.0, 0.1, 0.2, 0.0, 0.4, 950.0, 0.0, 540.0, 12.0, 0x3F)
    packet = Packer().pack(msg)
    assert isinstance(packet, MavlinkPacket)
    assert packet.data[0] == 0xFD
    (back,) = unpack(packet)
    assert isinstance(back, HilSensor)
    assert back.fields_updated == 0x3F
    assert read(packet, HilSensor) is not None
    assert math.isclose(back.zacc, -9.8, rel_tol=1e-6)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(px4st.missions(count=(1, 3), distance=(0.0, 120.0), altitude=(5.0, 30.0)))
def test_generated_missions_complete_at_low_fidelity(config: px4.Configuration) -> None:
    with px4.PX4(fidelity="low").start() as sim:
        result = sim.firmware.send(config)
    assert result.completed, result.reason
    assert [r.index for r in result.reached] == list(range(len(config.mission)))
    assert min(s.true_alt for s in result.trajectory) > -0.3


def test_path_gap_measures_where_two_flights_went() -> None:
    config = px4.Configuration([wp(20, 0, 8)], end="hold")
    with px4.PX4(fidelity="low").start() as sim:
        north = sim.firmware.send(config)
    with px4.PX4(fidelity="low").start() as sim:
        east = sim.firmware.send(px4.Configuration([wp(0, 20, 8)], end="hold"))
    assert north.path_gap(north) == (0.0, 0.0)
    mean, worst = north.path_gap(east)
    # The far end of one leg is about 20 m from the nearest point of the other (its start).
    assert worst == pytest.approx(20.0, abs=3.0)
    assert 0.0 < mean < worst
    with pytest.raises(mcs.ConfigurationError, match="above"):
        north.path_gap(east, above=100.0)


def test_packed_hil_frames_are_pymavlink_s_byte_for_byte_numbered_by_their_packer() -> None:
    import random

    import msgspec

    from multicosim.mavlink.dialect import dialect, new_link
    from multicosim.mavlink.hil import HilActuatorControls, HilGps, HilSensor, Packer

    rng = random.Random(0)
    ours, reference = Packer(), new_link(1, 1)
    d = dialect()
    messages: list[tuple[Any, Any]] = []
    for _ in range(300):
        sensor = [rng.uniform(-100, 100) for _ in range(13)]
        gps = [rng.randrange(0, 30000) for _ in range(7)]
        big = [rng.randrange(-(2**31), 2**31) for _ in range(3)]
        controls = [rng.uniform(-1, 1) for _ in range(16)]
        messages += [
            (
                msgspec.convert([rng.randrange(2**40), *sensor, 0x3F], HilSensor),
                d.MAVLink_hil_sensor_message,
            ),
            (
                msgspec.convert([rng.randrange(2**40), 3, *big, *gps, 12], HilGps),
                d.MAVLink_hil_gps_message,
            ),
            (
                HilActuatorControls(rng.randrange(2**40), controls, 1, 129),
                d.MAVLink_hil_actuator_controls_message,
            ),
        ]
    for msg, cls in messages:
        expected = bytes(cls(*msgspec.structs.astuple(msg)).pack(reference))
        reference.seq = (reference.seq + 1) & 0xFF
        assert ours.pack(msg).data == expected
    # Each packer numbers its own frames: another one starts again at 0.
    assert Packer().pack(messages[0][0]).data[4] == 0
