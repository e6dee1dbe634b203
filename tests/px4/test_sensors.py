"""The medium-fidelity world's sensors carry the noise of PX4's own Gazebo sensor models.

The quadrotor stands on the ground of the MuJoCo world for 30 simulated seconds; what its
sensors publish is compared with its true state: a GNSS fix within centimetres (no slowly
drifting offset: Gazebo's GPS bias decorrelates within a quarter second), and IMU noise of
the iris model's densities at the world's rate.
"""

from __future__ import annotations

import math
import statistics
from typing import Any

import multicosim as mcs
import multicosim.px4 as px4
from multicosim.core.geo import LocalProjection
from multicosim.mavlink.hil import HilGps, HilSensor
from multicosim.px4.scenario import WorldComponent
from multicosim.quadrotor.sensors import ACCEL_DENSITY, GYRO_DENSITY
from multicosim.quadrotor.topics import world_topics


def _readings(seconds: float) -> tuple[list[HilGps], list[HilSensor], Any]:
    world = px4.WorldConfig(period=0.004)
    topics = world_topics(world)
    gps: list[HilGps] = []
    imu: list[HilSensor] = []

    class Recorder:
        period = 0.004

        def setup(self, ctx: Any) -> None:
            self.gps = ctx.subscribe(topics.gps, HilGps)
            self.imu = ctx.subscribe(topics.imu, HilSensor)

        def step(self, ctx: Any) -> None:
            gps.extend(self.gps.messages)
            imu.extend(self.imu.messages)

    sim = mcs.ProcessSimulator(seed=3)
    # Native payloads: the models' noise itself, not MAVLink's 32-bit rounding of it.
    sim.add(WorldComponent(world, "medium", placement="in-process", wire="native"))
    sim.add(mcs.InProcessComponent(Recorder, "recorder"))
    with sim.start() as simulation:
        simulation.advance(seconds)
    return gps, imu, world


def test_gps_and_imu_noise_are_px4_gazebo_models() -> None:
    gps, imu, world = _readings(30.0)
    assert len(gps) > 250
    proj = LocalProjection(world.home.lat, world.home.lon)
    settled = gps[len(gps) // 10 :]
    # Standing still: every fix within 2 cm horizontally and 5 cm vertically of the truth.
    for fix in settled:
        n, e = proj.project(fix.lat * 1e-7, fix.lon * 1e-7)
        assert math.hypot(n, e) < 0.02, (n, e)
    alts = [fix.alt * 1e-3 for fix in settled]
    assert max(alts) - min(alts) < 0.05
    speeds = [fix.vd * 1e-2 for fix in settled]
    assert 0.005 < statistics.pstdev(speeds) < 0.06  # 0.4 (m/s)/sqrt(Hz) x sqrt(4 ms)
    # The IMU's white noise: density / sqrt(sample period).
    rest = imu[len(imu) // 10 :]
    gyro = statistics.pstdev(m.xgyro for m in rest)
    accel = statistics.pstdev(m.xacc for m in rest)
    assert 0.8 < gyro / (GYRO_DENSITY / math.sqrt(0.004)) < 1.25
    assert 0.8 < accel / (ACCEL_DENSITY / math.sqrt(0.004)) < 1.25
