"""Several vehicles in one world: their missions at once, and what happens between them.

With real PX4 (``px4_sitl``), several SITL instances fly one MuJoCo world in lockstep, each
on its instance's ports: our ground station flies some, MAVSDK another.
"""

from __future__ import annotations

import asyncio
import math
import re
import threading
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mavsdk_client import fly_mission
from pymavlink import mavutil

import multicosim as mcs
from multicosim import ardupilot, attacks, fleet, px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.udp import API_PORT
from multicosim.physics import Pose, WellClear
from multicosim.quadrotor import NONE_IRIS
from multicosim.trace import Recorder, read_trace
from multicosim.trace._plot import figure
from pytest_multicosim.px4 import RealPX4

HOME = px4.Home()
PROJ = LocalProjection(HOME.lat, HOME.lon)
REACH = 2 * NONE_IRIS.radius  # both bodies' radii
APART = 80.0  # m between the two starts, along north


wp = px4.Waypoint.local  # a waypoint north/east metres from home, alt above it


def head_on(
    alt_alpha: float, alt_bravo: float, time_limit: float = 90.0
) -> dict[str, px4.Configuration]:
    """Alpha flies north to bravo's start, bravo south to alpha's, each at its altitude."""
    return {
        "alpha": px4.Configuration([wp(APART, 0, alt_alpha)], end="land", time_limit=time_limit),
        "bravo": px4.Configuration([wp(0, 0, alt_bravo)], end="land", time_limit=time_limit),
    }


@pytest.fixture
def fleet_vehicles() -> dict[str, fleet.PX4Vehicle]:
    return {"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(north=APART))}


def _true(sample: px4.FlightSample) -> tuple[float, float, float]:
    """Where the world had the vehicle: north, east, up (m from home)."""
    north, east = PROJ.project(sample.true_lat, sample.true_lon)
    return north, east, sample.true_alt


def _crossing(result: fleet.FleetResult, reach: float) -> tuple[float, float]:
    """When the true centres first came within ``reach`` (interpolated between samples), and
    how fast they closed then: from the vehicles' own trajectories."""
    a, b = (result.results[n].trajectory for n in ("alpha", "bravo"))
    by_time = {round(s.time, 6): s for s in b}
    distances = [
        (s.time, math.dist(_true(s), _true(by_time[round(s.time, 6)])))
        for s in a
        if round(s.time, 6) in by_time
    ]
    for i in range(2, len(distances)):
        _, d = distances[i]
        if d <= reach:
            # How fast they closed before the contact (after it, they bounce).
            (t1, d1), (t0, d0) = distances[i - 1], distances[i - 2]
            closing = (d0 - d1) / (t1 - t0)
            return t1 + (d1 - reach) / closing, closing
    raise AssertionError("the centres never came within reach")


@pytest.mark.fidelity("low", "medium")
def test_head_on_at_one_altitude_is_a_collision_of_that_pair_when_they_meet(
    fleet_simulation: fleet.FleetSimulation, mcs_fidelity: str
) -> None:
    result = fleet_simulation.fly(head_on(10.0, 10.0))
    collisions = result.encounter.collisions
    assert collisions, "flown head-on at one altitude, they did not collide"
    first = collisions[0]
    assert (first.a, first.b) == ("alpha", "bravo")
    assert first.source == ("analytic" if mcs_fidelity == "low" else "contact")
    analytic, closing = _crossing(result, REACH)
    # Within one control period plus the time to cover the bodies' radii at that speed.
    period = 0.1 if mcs_fidelity == "low" else 0.05
    assert abs(first.time - analytic) <= period + REACH / closing
    assert first.speed == pytest.approx(closing, rel=0.5)
    assert result.encounter.min_separation() <= 0.0


@pytest.mark.fidelity("low", "medium")
def test_with_a_vertical_offset_the_closest_separation_is_the_offset(
    fleet_simulation: fleet.FleetSimulation, mcs_fidelity: str
) -> None:
    result = fleet_simulation.fly(head_on(10.0, 15.0))
    assert result.completed, {n: r.reason for n, r in result.results.items()}
    assert not result.encounter.collisions
    approach = result.encounter.closest["alpha-bravo"]
    tolerance = 0.2 if mcs_fidelity == "low" else 0.5
    assert approach.separation == pytest.approx(5.0 - REACH, abs=tolerance)
    assert 0.0 < approach.north < APART
    assert approach.up == pytest.approx(12.5, abs=tolerance)
    signals = result.encounter.signals()
    assert min(signals["separation"]) == pytest.approx(approach.separation)
    assert signals["separation_alpha_bravo"] == signals["separation"]


@pytest.fixture
def fleet_well_clear() -> WellClear:
    return WellClear(horizontal=20.0, vertical=10.0)


@pytest.mark.fidelity("low", "medium")
def test_well_clear_is_lost_where_its_thresholds_say(
    fleet_simulation: fleet.FleetSimulation,
) -> None:
    result = fleet_simulation.fly(head_on(10.0, 15.0))
    samples = result.encounter.pairs["alpha-bravo"]
    lost = [i for i, s in enumerate(samples) if not s.well_clear]
    assert lost, "they passed within 20 m and 5 m of each other and stayed well clear"
    for i, s in enumerate(samples):
        inside = s.horizontal <= 20.0 and s.vertical <= 10.0
        assert s.well_clear is not inside, (i, s)
    (interval,) = result.encounter.losses["alpha-bravo"]
    assert interval.start == samples[lost[0]].time
    assert interval.end == samples[lost[-1] + 1].time


@pytest.mark.fidelity("low", "medium")
def test_one_trace_holds_every_vehicle_and_its_plot_marks_the_closest_approach(
    fleet_simulator: fleet.Fleet, tmp_path: Path
) -> None:
    with fleet_simulator.start() as simulation, Recorder().attach(simulation) as recorder:
        result = simulation.fly(head_on(10.0, 15.0))
    recorder.save(tmp_path / "trace.mcap")
    tlog = recorder.save_tlog(tmp_path / "trace.tlog")
    assert tlog is not None
    trace = read_trace(tmp_path / "trace.mcap")
    # Each vehicle's channels are under its name; the pairs' samples are there too.
    for name in ("alpha", "bravo"):
        assert {f"{name}/pose", f"{name}/location/truth", f"mcs/plan/{name}"} <= set(trace.channels)
    samples = trace.topic("mcs/encounter/alpha/bravo")
    approach = result.encounter.closest["alpha-bravo"]
    assert min(m.data["separation"] for m in samples) == pytest.approx(approach.separation)
    # Bravo's path starts at its own start, 80 m north, in the one frame of the world.
    bravo = trace.topic("mcs/path/bravo/truth")
    assert bravo[0].data["north"] == pytest.approx(APART, abs=0.5)
    # The plot draws both paths and a line between the two at the closest approach.
    lines: dict[object, Any] = {
        line.get_gid(): line for ax in figure(trace).axes for line in ax.get_lines()
    }
    assert {"path/alpha/truth", "path/bravo/truth", "plan/alpha", "plan/bravo"} <= set(lines)
    marked = lines["approach/alpha/bravo"]
    south, north = sorted(marked.get_ydata())
    assert south <= approach.north <= north
    assert "closest alpha-bravo" in str(marked.get_label())
    # Without a requirement, the last panel is the pair's separation over time.
    separation = next(
        line for line in figure(trace).axes[2].get_lines() if "separation" in str(line.get_label())
    )
    assert float(np.min(np.asarray(separation.get_ydata()))) == pytest.approx(approach.separation)
    # The MAVLink log tells the vehicles apart by their system ids.
    heartbeats = mavutil.mavlink_connection(str(tlog))
    systems = set()
    try:
        while (m := heartbeats.recv_match(type="HEARTBEAT")) is not None:
            systems.add(m.get_srcSystem())
    finally:
        heartbeats.close()
    assert {1, 2} <= systems


def test_a_spoof_on_one_vehicle_moves_that_vehicle_only() -> None:
    def fly(spoofed: bool) -> fleet.FleetResult:
        simulator = fleet.Fleet(
            {"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(east=30.0))},
            fidelity="low",
        )
        if spoofed:
            # Bravo's GPS says 6 m east of where it is: it flies 6 m west of its leg.
            spoof = attacks.Jump(offset=attacks.Local(east=6.0), start=0.0, ramp=3.0)
            injector = attacks.inject(simulator, "bravo/gps", [spoof])
            assert injector.config.target == "bravo/gps/attacked"
        with simulator.start() as simulation:
            return simulation.fly(
                {
                    "alpha": px4.Configuration([wp(40, 0, 10)]),
                    "bravo": px4.Configuration([wp(40, 30, 10)]),
                }
            )

    clean, spoofed = fly(False), fly(True)
    for result in (clean, spoofed):
        assert result.completed, {n: r.reason for n, r in result.results.items()}

    def end(result: fleet.FleetResult, name: str) -> tuple[float, float, float]:
        return _true(result.results[name].trajectory[-1])

    assert end(spoofed, "bravo")[1] == pytest.approx(end(clean, "bravo")[1] - 6.0, abs=1.0)
    assert end(spoofed, "alpha") == pytest.approx(end(clean, "alpha"), abs=0.01)


@pytest.mark.parametrize(
    ("sensor", "says"),
    [
        ("gps", "'<vehicle>/<sensor>'"),
        ("charlie/gps", "'<vehicle>/<sensor>'"),
        ("alpha/sonar", "sonar"),
    ],
)
def test_a_fault_on_no_vehicle_s_sensor_is_refused(sensor: str, says: str) -> None:
    simulator = fleet.Fleet(
        {"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(east=30.0))}
    )
    with pytest.raises(mcs.ConfigurationError, match=re.escape(says)):
        attacks.inject(simulator, sensor, [attacks.Bias(offset=1.0)])


def test_overlapping_starts_are_refused_before_anything_starts() -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        fleet.Fleet({"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(east=0.2))})
    assert info.value.field == "vehicles['bravo'].start"
    assert "'alpha'" in str(info.value)


@pytest.mark.parametrize(
    ("vehicles", "field"),
    [
        ({}, "vehicles"),
        ({"1st": fleet.PX4Vehicle()}, "vehicles"),
        ({"alpha": "a PX4"}, "vehicles['alpha']"),
    ],
)
def test_bad_fleets_are_refused(vehicles: dict[str, object], field: str) -> None:
    with pytest.raises(mcs.ConfigurationError) as info:
        fleet.Fleet(vehicles)  # type: ignore[arg-type]
    assert info.value.field == field


def test_a_fleet_names_each_vehicles_topics_and_flies_missions_by_name() -> None:
    simulator = fleet.Fleet(
        {"alpha": fleet.PX4Vehicle(), "bravo": fleet.PX4Vehicle(start=Pose(east=30.0))},
        fidelity="low",
    )
    with simulator.start() as simulation:
        with pytest.raises(mcs.ConfigurationError, match="charlie"):
            simulation.fly({"charlie": head_on(10, 10)["alpha"]})
        result = simulation.fly({"bravo": px4.Configuration([wp(0, 30, 5)], end="land")})
    assert set(result.results) == {"bravo"}
    assert result.results["bravo"].completed
    assert min(_true(s)[1] for s in result.results["bravo"].trajectory) > 29.0


def test_two_real_px4_pass_each_other_at_their_altitudes(px4_sitl: RealPX4) -> None:
    simulator = fleet.Fleet(
        {
            "alpha": fleet.PX4Vehicle(firmware=px4_sitl.sitl()),
            "bravo": fleet.PX4Vehicle(firmware=px4_sitl.sitl(), start=Pose(north=APART)),
        },
        fidelity="medium",
        seed=3,
    )
    with simulator.start() as simulation:
        instances = {simulation.vehicles[n].instance for n in ("alpha", "bravo")}
        result = simulation.fly(head_on(10.0, 16.0, time_limit=240.0))
        # Each PX4's own flight log, named after its vehicle (both landed and disarmed).
        logs = simulation.flight_logs()
        assert sorted(p.name.split("-")[0] for p in logs) == ["alpha", "bravo"]
        assert all(p.suffix == ".ulg" and p.stat().st_size > 0 for p in logs)
    assert len(instances) == 2, "two PX4s shared an instance"
    assert result.completed, {n: r.reason for n, r in result.results.items()}
    assert not result.encounter.collisions
    approach = result.encounter.closest["alpha-bravo"]
    # Real PX4 holds each altitude: they pass with its difference between them.
    assert approach.separation == pytest.approx(6.0 - REACH, abs=1.5)
    assert 0.0 < approach.north < APART


@pytest.mark.xdist_group("px4-usual-ports")  # MAVSDK listens where PX4 SITL sends: 14540 + N
def test_mavsdk_flies_one_real_px4_while_the_fleet_flies_the_other(px4_sitl: RealPX4) -> None:
    pytest.importorskip("mavsdk.asyncio", reason="mavsdk (pip install mavsdk) not installed")
    if px4_sitl.binary is None:
        pytest.skip("PX4's usual ports on this host: a PX4 binary run as a process")
    simulator = fleet.Fleet(
        {
            "alpha": fleet.PX4Vehicle(firmware=px4_sitl.sitl(), placement="process"),
            "bravo": fleet.PX4Vehicle(
                firmware=px4_sitl.sitl(),
                placement="process",
                start=Pose(east=40.0),
                own_links=True,
            ),
        },
        fidelity="medium",
        seed=4,
        realtime=2.0,  # MAVSDK waits on the wall clock
    )
    seen: dict[str, Any] = {}

    with simulator.start() as simulation:
        port = API_PORT + simulation.vehicles["bravo"].instance

        def client() -> None:
            try:
                seen.update(asyncio.run(fly_mission(port, (HOME.lat, HOME.lon), [(30.0, 40.0)])))
            except BaseException as exc:  # the test's thread reports it
                seen["error"] = exc

        thread = threading.Thread(target=client, daemon=True)
        thread.start()
        with pytest.raises(mcs.ConfigurationError, match="own links"):
            simulation.fly({"bravo": head_on(10.0, 10.0)["bravo"]})
        result = simulation.fly({"alpha": px4.Configuration([wp(30, 0, 10)], end="land")})
        while thread.is_alive() and simulation.time < 600.0:
            simulation.advance(0.5)
        thread.join(timeout=10)
    assert "error" not in seen, seen.get("error")
    assert result.results["alpha"].completed, result.results["alpha"].reason
    assert seen["autopilot"] == seen["expected_autopilot"]
    assert seen["progress"] == (1, 1)
    pos = seen["position"]
    north, east = PROJ.project(pos.latitude_deg, pos.longitude_deg)
    assert math.dist((north, east), (30.0, 40.0)) < 5.0, "MAVSDK's PX4 is not at its waypoint"


@pytest.mark.xdist_group("px4-usual-ports")  # MAVSDK listens where PX4 SITL sends: 14540 + N
def test_every_kind_of_autopilot_flies_one_world_while_mavsdk_flies_a_real_px4(
    px4_sitl: RealPX4, ardupilot_dir: str
) -> None:
    """Two real PX4 (MAVSDK flies the second, on its instance's usual port), the built-in
    autopilot and ArduCopter each fly their own mission, ArduRover drives below them."""
    pytest.importorskip("mavsdk.asyncio", reason="mavsdk (pip install mavsdk) not installed")
    if px4_sitl.binary is None:
        pytest.skip("PX4's usual ports on this host: a PX4 binary run as a process")
    real = px4_sitl.sitl()
    copter = ardupilot.SITL(directory=ardupilot_dir)
    simulator = fleet.Fleet(
        {
            "px4": fleet.PX4Vehicle(firmware=real, placement="process"),
            "mavsdk": fleet.PX4Vehicle(
                firmware=real, placement="process", start=Pose(east=15.0), own_links=True
            ),
            "builtin": fleet.PX4Vehicle(start=Pose(east=30.0)),
            "copter": fleet.ArduPilotVehicle(firmware=copter, start=Pose(east=45.0)),
            "rover": fleet.ArduPilotVehicle(firmware=copter, kind="rover", start=Pose(east=-15.0)),
        },
        fidelity="medium",
        seed=5,
        realtime=1.0,  # MAVSDK waits on the wall clock
    )
    seen: dict[str, Any] = {}
    missions = {
        name: px4.Configuration([wp(40, east, 10)], end="land", time_limit=300.0)
        for name, east in (("px4", 0.0), ("builtin", 30.0), ("copter", 45.0))
    }
    # The rover drives north, then east beneath the vehicles' paths (clear of where they land).
    missions["rover"] = px4.Configuration(
        [wp(20, -15, 0), wp(20, 30, 0)], cruise_speed=3.0, time_limit=300.0
    )
    with simulator.start() as simulation:
        instances = {n: simulation.vehicles[n].instance for n in ("px4", "mavsdk")}
        port = API_PORT + instances["mavsdk"]

        def client() -> None:
            try:
                out = fly_mission(port, (HOME.lat, HOME.lon), [(40.0, 15.0)], timeout=240.0)
                seen.update(asyncio.run(out))
            except BaseException as exc:  # the test's thread reports it
                seen["error"] = exc

        thread = threading.Thread(target=client, daemon=True)
        thread.start()
        result = simulation.fly(missions, timeout=1800.0)  # paced at real time
        while thread.is_alive() and simulation.time < 900.0:
            simulation.advance(0.5)
        thread.join(timeout=10)
    assert "error" not in seen, seen.get("error")
    assert len(set(instances.values())) == 2
    for name, flown in result.results.items():
        assert flown.completed, (name, flown.reason)
    end = _true(result.results["rover"].trajectory[-1])
    assert math.dist(end[:2], (20.0, 30.0)) < 3.0, "the rover did not reach its last point"
    assert seen["progress"] == (1, 1)
    pos = seen["position"]
    north, east = PROJ.project(pos.latitude_deg, pos.longitude_deg)
    assert math.dist((north, east), (40.0, 15.0)) < 5.0, "MAVSDK's PX4 is not at its waypoint"
    # Every pair was measured on the one clock, the rover's with the vehicles above it.
    names = list(simulator.vehicles)
    assert set(result.encounter.closest) == {f"{a}-{b}" for a, b in combinations(names, 2)}
    assert min(s.vertical for s in result.encounter.pairs["builtin-rover"]) < 1.0
    assert not result.encounter.collisions
