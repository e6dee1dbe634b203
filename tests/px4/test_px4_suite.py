"""PX4's own MAVSDK multicopter tests, ported to MAVSDK-Python, on both autopilots.

PX4 tests its releases with MAVSDK test cases (``test/mavsdk_tests`` in PX4-Autopilot:
``autopilot_tester.*`` and ``test_multicopter_*.cpp``). These are the 30 multicopter cases
of the mission, basics, offboard, manual, failsafe, failure-injection, follow-me, goto,
RTL and DO_JUMP files, with PX4's steps, tolerances and timeouts; timeouts and sleeps are simulated
seconds, measured on the autopilot's clock (its ATTITUDE_QUATERNION timestamps, as PX4's
tester does), so a loaded machine changes nothing but the wall time. They run at the speed
factor PX4's CI runs them at (``SPEED``), which decides how often the tester looks and how
long PX4 waits for a client's sticks and setpoints.

Each case flies the built-in autopilot at medium fidelity (``multicosim px4 sitl``) and,
with ``--mcs-px4-binary``, real PX4 SITL flying the same MuJoCo world: both standalone, with
MAVSDK on their API link over loopback UDP. Cases that need what our world does not
simulate are skipped with the reason. Expected failures name what makes them fail on both
autopilots (they are the same on both: the built-in autopilot passes every case real PX4
passes here).
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Awaitable, Callable
from typing import Any

import pytest

from multicosim.core.geo import LocalProjection
from pytest_multicosim.px4 import real_px4

pytest.importorskip("mavsdk.asyncio", reason="mavsdk (pip install mavsdk) not installed")

MAV_AUTOPILOT_INVALID = 8  # a ground station's heartbeat
# Simulated seconds per wall second (PX4_SIM_SPEED_FACTOR): the speed factor PX4's CI runs this
# suite at (.github/workflows/sitl_tests.yml at v1.15: `mavsdk_test_runner.py --speed-factor
# 10`). What a case sees depends on it: PX4's tester looks at a condition every timeout/100
# *wall* seconds (poll_condition_with_timeout sleeps with std::this_thread), every timeout/10
# simulated seconds at that speed, and PX4's rcS scales COM_RC_LOSS_T and COM_OF_LOSS_T with it
# (0.5 s each per unit of speed), so that stick and setpoint streams sent on the wall clock
# are not taken for lost.
SPEED = 10.0
API_PORT = 14540
WALL_SLACK = 120.0  # wall seconds beyond a simulated timeout before a stalled run is failed

pytestmark = pytest.mark.xdist_group("px4_suite")

BOTH = ("builtin", "sitl")
NO_GOTO_MODE = (
    "PX4 v1.15 has no Goto flight mode (AUTO sub mode 21 came in a later PX4): DO_REPOSITION "
    "flies there in Hold"
)
FAILURE_INJECTION_ENABLED = (
    "PX4 v1.15's SITL start-up sets SYS_FAILURE_EN=1 (etc/init.d-posix/rcS): the motor failure "
    "is injected, not refused as disabled"
)
# Cases whose outcome may differ between the two autopilots, each with the PX4 v1.15 source
# that explains it. Any other difference fails the run (tests/px4_agreement.py compares the
# outcomes of every case flown on both).
KNOWN_DIFFERENCES: dict[str, str] = {}
# Cases whose outcome differs and whose cause is not found yet: what was measured. They do not
# fail the run, and the agreement summary lists them, so each stays in sight until explained.
OPEN_DIFFERENCES: dict[str, str] = {}
SET_CURRENT_ONTO_DO_JUMP = (
    "PX4 v1.15 takes MISSION_SET_CURRENT's index verbatim and loads the DO_JUMP itself as the "
    "current item (navigator/mission_base.cpp, MissionBase::updateMavlinkMission: "
    "`_mission = new_mission;` then set_mission_items()): an idle setpoint, the mission waits "
    "in the air; later PX4 resolves the jump, which this case was written for"
)
# Cases that fail on real PX4 v1.15.4 flying our world, and why; strict where the failure is
# certain (real PX4's own runs vary: its modules are threads).
EXPECTED_FAILURES: dict[str, tuple[tuple[str, ...], str, bool]] = {
    "test_goto_reposition_flies_to_and_holds_at_the_target": (BOTH, NO_GOTO_MODE, False),
    "test_goto_pausing_mid_reposition_switches_to_hold": (BOTH, NO_GOTO_MODE, False),
    "test_goto_speed_change_while_flying_is_applied": (BOTH, NO_GOTO_MODE, False),
    "test_failure_injection_reject_mid_air_when_it_is_disabled": (
        BOTH,
        FAILURE_INJECTION_ENABLED,
        False,
    ),
    "test_failure_injection_reject_before_arming": (BOTH, FAILURE_INJECTION_ENABLED, True),
    "test_mission_with_an_external_set_current_onto_a_do_jump_item": (
        BOTH,
        SET_CURRENT_ONTO_DO_JUMP,
        True,
    ),
}


class Failed(AssertionError):
    """A REQUIRE of PX4's tester failed: the case stops here."""


# -- the tester: PX4's AutopilotTester, in Python ------------------------------------------


class Tester:
    """What PX4's ``AutopilotTester`` does, with MAVSDK-Python."""

    __test__ = False  # not a test class

    def __init__(self, system: Any) -> None:
        from mavsdk.asyncio.plugins.action import ActionAsync
        from mavsdk.asyncio.plugins.failure import FailureAsync
        from mavsdk.asyncio.plugins.follow_me import FollowMeAsync
        from mavsdk.asyncio.plugins.manual_control import ManualControlAsync
        from mavsdk.asyncio.plugins.mavlink_direct import MavlinkDirectAsync
        from mavsdk.asyncio.plugins.mission import MissionAsync
        from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
        from mavsdk.asyncio.plugins.offboard import OffboardAsync
        from mavsdk.asyncio.plugins.param import ParamAsync
        from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

        self.system = system
        self.action = ActionAsync(system)
        self.failure = FailureAsync(system)
        self.follow_me = FollowMeAsync(system)
        self.manual = ManualControlAsync(system)
        self.direct = MavlinkDirectAsync(system)
        self.mission = MissionAsync(system)
        self.mission_raw = MissionRawAsync(system)
        self.offboard = OffboardAsync(system)
        self.param = ParamAsync(system)
        self.telemetry = TelemetryAsync(system)
        self.checks: list[str] = []  # failed CHECKs: the case goes on, and fails at the end
        self.home: Any = None
        self.custom_mode = -1
        self.sysid = 1
        self._tasks: list[asyncio.Task[None]] = []
        self._sim_us = 0

    # Simulated time, from the autopilot's attitude timestamps.

    async def start(self) -> None:
        self._tasks.append(asyncio.create_task(self._clock()))
        self._tasks.append(asyncio.create_task(self._heartbeats()))

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)

    async def _clock(self) -> None:
        async for q in self.telemetry.subscribe_attitude_quaternion():
            if q.timestamp_us > self._sim_us:
                self._sim_us = q.timestamp_us

    async def _heartbeats(self) -> None:
        import json

        async for m in self.direct.subscribe_message("HEARTBEAT"):
            fields = json.loads(m.fields_json)
            # The autopilot's own heartbeat (PX4 instance N is system N + 1).
            if m.component_id == 1 and fields["autopilot"] != MAV_AUTOPILOT_INVALID:
                self.sysid = m.system_id
                self.custom_mode = int(fields["custom_mode"])

    @property
    def now(self) -> float:
        """The autopilot's simulated time (s)."""
        return self._sim_us * 1e-6

    async def sleep_for(self, seconds: float) -> None:
        await self.poll(lambda: _false(), seconds, "", fail=False)

    async def poll(
        self,
        cond: Callable[[], Awaitable[bool]],
        timeout: float,
        what: str,
        *,
        fail: bool = True,
    ) -> bool:
        """Whether ``cond`` came true within ``timeout`` simulated seconds (REQUIRE if fail).

        As PX4's tester, it looks every ``timeout / 100`` wall seconds at ``SPEED``: ten times
        per timeout, on the autopilot's clock (a sleep is looked at every 1 ms).
        """
        while self._sim_us == 0:
            await asyncio.sleep(0.01)
        start = self.now
        wall = time.monotonic() + timeout / SPEED + WALL_SLACK
        step = timeout * SPEED / 100 if what else 0.001
        while True:
            if await cond():
                return True
            looked = self.now
            while self.now - looked < step and self.now - start < timeout:
                if time.monotonic() > wall:
                    raise Failed(f"the simulation stalled while waiting for {what or 'time'}")
                await asyncio.sleep(0.002)
            if self.now - start >= timeout:
                break
        if fail:
            raise Failed(f"timed out after {timeout:g} s (simulated) waiting for {what}")
        return False

    def check(self, ok: bool, what: str) -> None:
        """PX4's CHECK: record a failure and go on."""
        if not ok:
            self.checks.append(f"{what} (t={self.now:.1f} s)")

    # The steps of PX4's tester.

    async def wait_until_ready(self) -> None:
        t = self.telemetry
        ok = await self.poll(_ok(t.health_all_ok), 30, "health all ok", fail=False)
        self.check(ok, "health_all_ok within 30 s")

        async def armable() -> bool:
            return bool((await t.health()).is_armable)

        self.check(await self.poll(armable, 45, "armable", fail=False), "armable within 45 s")

    async def store_home(self) -> None:
        self.check(await _succeeds(self.telemetry.set_rate_ground_truth(15)), "ground truth rate")

        async def has_home() -> bool:
            self.home = await self.telemetry.ground_truth()
            return math.isfinite(self.home.latitude_deg) and math.isfinite(self.home.longitude_deg)

        self.check(await self.poll(has_home, 10, "ground truth", fail=False), "home stored")

    async def _ground_truth_distance(self, target: Any) -> float:
        current = await self.telemetry.ground_truth()
        if not (math.isfinite(target.latitude_deg) and math.isfinite(current.latitude_deg)):
            return math.nan
        n, e = LocalProjection(target.latitude_deg, target.longitude_deg).project(
            current.latitude_deg, current.longitude_deg
        )
        return math.hypot(n, e)

    async def check_home_within(self, radius: float) -> None:
        d = await self._ground_truth_distance(self.home)
        self.check(d < radius, f"home within {radius} m (distance {d:.1f} m)")

    async def check_home_not_within(self, radius: float) -> None:
        d = await self._ground_truth_distance(self.home)
        self.check(d > radius, f"home not within {radius} m (distance {d:.1f} m)")

    async def set_takeoff_altitude(self, alt: float) -> None:
        self.check(await _succeeds(self.action.set_takeoff_altitude(alt)), "set takeoff altitude")
        got = await _value(self.action.get_takeoff_altitude())
        self.check(got is not None and abs(got - alt) < 1e-3, "takeoff altitude read back")

    async def set_param_int(self, name: str, value: int) -> None:
        self.check(await _succeeds(self.param.set_param_int(name, value)), f"set {name}")

    async def arm(self) -> None:
        await self.poll(_ok(self.action.arm), 30, "arming")

    async def takeoff(self) -> None:
        if not await _succeeds(self.action.takeoff()):
            raise Failed("takeoff refused")

    async def land(self) -> None:
        if not await _succeeds(self.action.land()):
            raise Failed("land refused")

    async def execute_rtl(self) -> None:
        if not await _succeeds(self.action.return_to_launch()):
            raise Failed("return to launch refused")

    async def wait_until_disarmed(self, timeout: float) -> None:
        async def disarmed() -> bool:
            return not await self.telemetry.armed()

        await self.poll(disarmed, timeout, "disarmed")

    async def wait_for_landed_state(self, state: Any, timeout: float) -> None:
        async def landed() -> bool:
            return bool(await self.telemetry.landed_state() == state)

        await self.poll(landed, timeout, f"landed state {state.name}")

    async def wait_until_hovering(self) -> None:
        from mavsdk.asyncio.plugins.telemetry import LandedState

        await self.wait_for_landed_state(LandedState.IN_AIR, 45)

    async def wait_until_altitude(self, rel: float, timeout: float, delta: float = 0.1) -> None:
        async def there() -> bool:
            pv = await self.telemetry.position_velocity_ned()
            return bool(abs(rel + pv.position.down_m) <= delta)

        await self.poll(there, timeout, f"altitude {rel} m +- {delta}")

    async def position_ned(self) -> tuple[float, float, float]:
        p = (await self.telemetry.position_velocity_ned()).position
        return p.north_m, p.east_m, p.down_m

    async def projection(self) -> LocalProjection:
        home = await self.telemetry.home()
        self.check(math.isfinite(home.latitude_deg), "home position known")
        return LocalProjection(home.latitude_deg, home.longitude_deg)

    # Missions.

    async def _upload(self, legs: list[tuple[float, float]], options: Options) -> None:
        from mavsdk.asyncio.plugins.mission import MissionItem, MissionPlan

        proj = await self.projection()
        items = []
        for n, e in legs:
            lat, lon = proj.reproject(n, e)
            items.append(
                MissionItem(
                    latitude_deg=lat,
                    longitude_deg=lon,
                    relative_altitude_m=options.altitude,
                    is_fly_through=options.fly_through,
                )
            )
        await self.mission.set_return_to_launch_after_mission(options.rtl_at_end)
        if not await _succeeds(self.mission.upload_mission(MissionPlan(items))):
            raise Failed("mission upload")
        await self.sleep_for(1)  # PX4 needs time to realize it has a mission

    async def prepare_square_mission(self, options: Options) -> None:
        leg = options.leg
        await self._upload([(leg, 0.0), (leg, leg), (0.0, leg)], options)

    async def prepare_straight_mission(self, options: Options) -> None:
        leg = options.leg
        await self._upload([(i * leg, 0.0) for i in range(5)], options)

    async def mission_finished(self) -> bool:
        return bool(await _value(self.mission.is_mission_finished()))

    async def execute_mission(self) -> None:
        await self.poll(_ok(self.mission.start_mission), 3, "mission start")
        await self.poll(self.mission_finished, 500, "mission finished")

    async def start_and_wait_for_mission_sequence(self, seq: int) -> None:
        if not await _succeeds(self.mission.start_mission()):
            raise Failed("mission start")

        async def reached() -> bool:
            return bool((await self.mission.mission_progress()).current >= seq)

        await self.poll(reached, 60, f"mission item {seq}")

    async def lose(self, unit: Any, kind: Any, finish_within: float | None) -> None:
        """execute_mission_and_lose_* / _get_*_stuck of PX4's tester."""
        await self.set_param_int("SYS_FAILURE_EN", 1)
        await self.start_and_wait_for_mission_sequence(1)
        self.check(await _succeeds(self.failure.inject(unit, kind, 0)), "failure injected")
        if finish_within is not None:
            await self.poll(self.mission_finished, finish_within, "mission finished")

    def monitor(self, coro: Awaitable[None]) -> None:
        """Run a telemetry check alongside the case (PX4's subscriptions)."""
        self._tasks.append(asyncio.ensure_future(coro))

    async def _mission_legs(self) -> list[tuple[float, float, float]]:
        plan = await _value(self.mission.download_mission())
        proj = await self.projection()
        legs = []
        for item in plan.mission_items if plan is not None else []:
            n, e = proj.project(item.latitude_deg, item.longitude_deg)
            legs.append((n, e, -item.relative_altitude_m))
        return legs

    def check_tracks_mission(self, corridor: float) -> None:
        async def watch() -> None:
            legs = await self._mission_legs()
            await _succeeds(self.telemetry.set_rate_position_velocity_ned(5))
            async for pv in self.telemetry.subscribe_position_velocity_ned():
                progress = await self.mission.mission_progress()
                if 0 < progress.current < progress.total and progress.current < len(legs):
                    p = (pv.position.north_m, pv.position.east_m, pv.position.down_m)
                    d = _line_distance(p, legs[progress.current - 1], legs[progress.current])
                    self.check(d < corridor, f"within {corridor} m of the track ({d:.1f} m)")

        self.monitor(watch())

    def check_mission_item_speed_above(self, index: int, speed: float) -> None:
        async def watch() -> None:
            await _succeeds(self.telemetry.set_rate_velocity_ned(10))
            async for v in self.telemetry.subscribe_velocity_ned():
                if (await self.mission.mission_progress()).current == index:
                    h = math.hypot(v.north_m_s, v.east_m_s)
                    self.check(h > speed, f"faster than {speed} m/s on item {index} ({h:.1f})")

        self.monitor(watch())

    def start_checking_altitude(self, down: float, max_deviation: float) -> None:
        async def watch() -> None:
            async for pv in self.telemetry.subscribe_position_velocity_ned():
                dev = abs(down - pv.position.down_m)
                self.check(dev <= max_deviation, f"altitude within {max_deviation} m ({dev:.2f})")

        self.monitor(watch())

    # Offboard and manual control.

    async def start_offboard(self, resend: Callable[[], Awaitable[None]]) -> None:
        for _ in range(10):
            if await _succeeds(self.offboard.start()):
                return
            await resend()
            await asyncio.sleep(0.02)
        raise Failed("offboard start")

    async def offboard_goto(self, target: Any, radius: float, timeout: float) -> None:
        await self.offboard.set_position_ned(target)
        await self.start_offboard(lambda: self.offboard.set_position_ned(target))

        async def close() -> bool:
            p = await self.position_ned()
            d = math.dist(p, (target.north_m, target.east_m, target.down_m))
            return d < radius

        self.check(await self.poll(close, timeout, "offboard target", fail=False), "reached")

    async def offboard_land(self) -> None:
        from mavsdk.asyncio.plugins.offboard import VelocityNedYaw

        await self.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 1.0, 0.0))

    async def sticks(self, x: float, y: float, z: float, r: float, seconds: float) -> None:
        """MANUAL_CONTROL at 50 Hz (simulated) for ``seconds``."""
        end = self.now + seconds
        while self.now < end:
            self.check(
                await _succeeds(self.manual.set_manual_control_input(x, y, z, r)), "manual input"
            )
            await self.sleep_for(0.02)

    async def fly_forward(self, start_mode: Callable[[], Awaitable[None]]) -> None:
        """fly_forward_in_posctl / _altctl of PX4's tester."""
        await self.sticks(0.0, 0.0, 0.5, 0.0, 1.0)
        self.check(await _succeeds(start_mode()), "manual mode started")
        await self.sticks(0.0, 0.0, 0.5, 0.0, 1.0)
        await self.store_home()
        await self.sticks(0.0, 0.0, 0.5, 0.0, 1.0)
        await self.wait_until_ready()
        await self.sticks(0.0, 0.0, 0.5, 0.0, 1.0)
        await self.arm()
        await self.sticks(0.0, 0.0, 0.5, 0.0, 1.0)
        await self.sticks(0.0, 0.0, 1.0, 0.0, 5.0)  # climb
        await self.sticks(0.5, 0.0, 0.5, 0.0, 10.0)  # forward
        for _ in range(60 * 50):  # descend until landed
            await self.sticks(0.0, 0.0, 0.0, 0.0, 0.02)
            if not await self.telemetry.in_air():
                break

    async def raw_gps_altitude(self) -> float:
        return float((await self.telemetry.raw_gps()).absolute_altitude_m)


class Options:
    """PX4's MissionOptions."""

    def __init__(
        self,
        *,
        leg: float = 20.0,
        altitude: float = 10.0,
        rtl_at_end: bool = False,
        fly_through: bool = False,
    ) -> None:
        self.leg, self.altitude, self.rtl_at_end, self.fly_through = (
            leg,
            altitude,
            rtl_at_end,
            fly_through,
        )


async def _false() -> bool:
    return False


async def _succeeds(aw: Awaitable[Any]) -> bool:
    from mavsdk.asyncio import MavsdkError

    try:
        await aw
    except MavsdkError:
        return False
    return True


async def _value(aw: Awaitable[Any]) -> Any:
    from mavsdk.asyncio import MavsdkError

    try:
        return await aw
    except MavsdkError:
        return None


def _ok(fn: Callable[[], Awaitable[Any]]) -> Callable[[], Awaitable[bool]]:
    async def call() -> bool:
        from mavsdk.asyncio import MavsdkError

        try:
            value = await fn()
        except MavsdkError:
            return False
        return value is None or bool(value)

    return call


def _line_distance(p: tuple[float, ...], a: tuple[float, ...], b: tuple[float, ...]) -> float:
    ab = [bi - ai for ai, bi in zip(a, b, strict=True)]
    ap = [pi - ai for ai, pi in zip(a, p, strict=True)]
    n2 = sum(v * v for v in ab)
    t = 0.0 if n2 == 0 else max(0.0, min(1.0, sum(x * y for x, y in zip(ab, ap, strict=True)) / n2))
    closest = [ai + t * v for ai, v in zip(a, ab, strict=True)]
    return math.dist(p, closest)


# -- the vehicles ------------------------------------------------------------------------------


@pytest.fixture(params=["builtin", "sitl"])
def autopilot(request: pytest.FixtureRequest) -> str:
    """Which autopilot flies: the built-in one (medium fidelity) or real PX4 SITL."""
    if request.param == "sitl" and real_px4(request.config).binary is None:
        pytest.skip("real PX4 needs a SITL binary (--mcs-px4-binary or MCS_PX4_BINARY)")
    expected = EXPECTED_FAILURES.get(getattr(request.node, "originalname", ""))
    if expected is not None and request.param in expected[0]:
        request.node.add_marker(pytest.mark.xfail(reason=expected[1], strict=expected[2]))
    return str(request.param)


@pytest.fixture
def vehicle(autopilot: str, request: pytest.FixtureRequest, sitl: Any, udp_port: int) -> Any:
    """Run a case against ``autopilot``: ``vehicle(case)`` runs ``case(tester)``."""

    def run(case: Callable[[Tester], Awaitable[None]]) -> None:
        if autopilot == "builtin":
            args: tuple[str, ...] = ("--fidelity", "medium", "--gcs-port", "0")
            args += ("--api-port", str(udp_port))
            ready = "ready"
        else:
            binary = real_px4(request.config).binary
            assert binary is not None
            args, ready = ("--px4-binary", binary), r"real PX4 SITL instance (\d+)"
        with sitl(*args, "--speed", str(SPEED), ready=ready, timeout=120.0) as proc:
            port = udp_port if autopilot == "builtin" else API_PORT + int(proc.ready.group(1))
            asyncio.run(_fly(port, case))

    return run


async def _fly(port: int, case: Callable[[Tester], Awaitable[None]]) -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=25.0)
        assert system is not None, "MAVSDK saw no autopilot within 25 s"
        tester = Tester(system)
        await tester.start()
        try:
            await case(tester)
        finally:
            await tester.stop()
        assert tester.checks == [], tester.checks


# -- test_multicopter_mission.cpp ----------------------------------------------------------


def test_takeoff_and_land(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.arm()
        await t.takeoff()
        await t.wait_until_hovering()
        await t.land()
        await t.wait_until_disarmed(180)

    vehicle(case)


def test_fly_square_multicopter_missions_including_rtl(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.prepare_square_mission(Options(rtl_at_end=True))
        await t.arm()
        await t.execute_mission()
        await t.wait_until_disarmed(180)

    vehicle(case)


def test_fly_square_multicopter_missions_with_manual_rtl(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.prepare_square_mission(Options(rtl_at_end=False))
        t.check_tracks_mission(5.0)
        await t.arm()
        await t.execute_mission()
        await t.wait_until_hovering()
        await t.execute_rtl()
        await t.wait_until_disarmed(180)

    vehicle(case)


def test_fly_straight_multicopter_mission(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.prepare_straight_mission(Options(rtl_at_end=False, fly_through=True))
        t.check_mission_item_speed_above(2, 4.0)
        t.check_tracks_mission(5.0)
        await t.arm()
        await t.execute_mission()
        await t.wait_until_hovering()
        await t.execute_rtl()
        await t.wait_until_disarmed(180)

    vehicle(case)


# -- test_multicopter_basics.cpp -----------------------------------------------------------


def test_takeoff_and_hold_position(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.set_takeoff_altitude(10.0)
        await t.store_home()
        await t.sleep_for(1)
        await t.arm()
        await t.takeoff()
        await t.wait_until_hovering()
        await t.wait_until_altitude(10.0, 30, 0.25 + 0.1)
        t.start_checking_altitude((await t.position_ned())[2], 0.25)
        await t.sleep_for(60)

    vehicle(case)


# -- test_multicopter_offboard.cpp ---------------------------------------------------------

RCL_EXCEPT_OFFBOARD = 1 << 2


def test_offboard_takeoff_and_land(vehicle: Any) -> None:
    from mavsdk.asyncio.plugins.offboard import PositionNedYaw

    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.store_home()
        await t.set_param_int("COM_RCL_EXCEPT", RCL_EXCEPT_OFFBOARD)
        await t.arm()
        await t.offboard_goto(PositionNedYaw(0.0, 0.0, -2.0, 0.0), 0.3, 90)
        await t.offboard_land()
        await t.wait_until_disarmed(120)
        await t.check_home_within(2.0)

    vehicle(case)


def test_offboard_position_control(vehicle: Any) -> None:
    from mavsdk.asyncio.plugins.offboard import PositionNedYaw

    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.store_home()
        await t.set_param_int("COM_RCL_EXCEPT", RCL_EXCEPT_OFFBOARD)
        await t.arm()
        takeoff = PositionNedYaw(0.0, 0.0, -2.0, 0.0)
        for target in (
            takeoff,
            PositionNedYaw(0.0, 5.0, -2.0, 180.0),
            PositionNedYaw(5.0, 5.0, -4.0, 180.0),
            PositionNedYaw(5.0, 0.0, -4.0, 90.0),
            takeoff,
        ):
            await t.offboard_goto(target, 0.3, 10)
        await t.offboard_land()
        await t.wait_until_disarmed(120)
        await t.check_home_within(2.0)

    vehicle(case)


def test_offboard_attitude_control(vehicle: Any) -> None:
    from mavsdk.asyncio.plugins.offboard import Attitude

    async def case(t: Tester) -> None:
        await t.set_param_int("COM_RCL_EXCEPT", RCL_EXCEPT_OFFBOARD)

        async def steady() -> bool:
            att = await t.telemetry.attitude_euler()
            gps_alt = await t.raw_gps_altitude()
            return gps_alt > 0 and abs(att.roll_deg) < 5 and abs(att.pitch_deg) < 5

        t.check(await t.poll(steady, 20, "raw GPS and a level attitude", fail=False), "steady")
        start_alt = await t.raw_gps_altitude()
        attitude = Attitude(0.0, 0.0, 0.0, 0.0)
        await t.offboard.set_attitude(attitude)
        await t.start_offboard(lambda: t.offboard.set_attitude(attitude))

        async def armable() -> bool:
            return bool((await t.telemetry.health()).is_armable)

        t.check(await t.poll(armable, 20, "armable", fail=False), "armable")
        await t.arm()

        async def hold(att: Any, seconds: float, until: Callable[[], Awaitable[bool]]) -> None:
            end = t.now + seconds
            while t.now < end and not await until():
                t.check(await _succeeds(t.offboard.set_attitude(att)), "attitude setpoint")
                await t.sleep_for(0.02)

        async def climbed() -> bool:
            return await t.raw_gps_altitude() - start_alt >= 10.0

        await hold(Attitude(0.0, 0.0, 0.0, 0.8), math.inf, climbed)
        forward = Attitude(0.0, -20.0, 0.0, 0.8)
        await hold(forward, 3.0, _false)
        att = await t.telemetry.attitude_euler()
        t.check(abs(att.roll_deg - forward.roll_deg) < 5, f"roll {att.roll_deg:.1f}")
        t.check(abs(att.pitch_deg - forward.pitch_deg) < 5, f"pitch {att.pitch_deg:.1f}")
        await hold(Attitude(0.0, 0.0, 0.0, 0.4), 6.0, _false)
        t.check(await _succeeds(t.offboard.set_attitude(Attitude(0.0, 0.0, 0.0, 0.0))), "cut")
        await t.wait_until_disarmed(120)

    vehicle(case)


# -- test_multicopter_manual.cpp -----------------------------------------------------------


def test_fly_forward_in_position_control(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.fly_forward(t.manual.start_position_control)
        await t.wait_until_disarmed(180)
        await t.check_home_not_within(5.0)

    vehicle(case)


def test_fly_forward_in_altitude_control(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.fly_forward(t.manual.start_altitude_control)
        await t.wait_until_disarmed(180)
        await t.check_home_not_within(5.0)

    vehicle(case)


# -- test_multicopter_failsafe.cpp ---------------------------------------------------------

HEIGHT_BARO, HEIGHT_GPS = 0, 1


def _failsafe_case(
    unit: str, kind: str, height: int | None, finish: float | None, disarm: float
) -> Callable[[Tester], Awaitable[None]]:
    async def case(t: Tester) -> None:
        from mavsdk.asyncio.plugins.failure import FailureType, FailureUnit

        if height is not None:
            await t.set_param_int("EKF2_HGT_REF", height)
        await t.wait_until_ready()
        await t.prepare_square_mission(Options(rtl_at_end=True))
        await t.arm()
        await t.lose(FailureUnit[unit], FailureType[kind], finish)
        await t.wait_until_disarmed(disarm)

    return case


def test_land_on_gps_lost_during_mission_baro_height(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_GPS", "OFF", HEIGHT_BARO, None, 30))


def test_land_on_gps_lost_during_mission_gps_height(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_GPS", "OFF", HEIGHT_GPS, None, 30))


def test_continue_on_mag_lost_during_mission(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_MAG", "OFF", None, 90, 120))


def test_continue_on_mag_stuck_during_mission(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_MAG", "STUCK", None, 120, 90))


def test_continue_on_baro_lost_during_mission_baro_height(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_BARO", "OFF", HEIGHT_BARO, 90, 90))


def test_continue_on_baro_lost_during_mission_gps_height(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_BARO", "OFF", HEIGHT_GPS, 90, 90))


def test_continue_on_baro_stuck_during_mission_baro_height(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_BARO", "STUCK", HEIGHT_BARO, 90, 90))


def test_continue_on_baro_stuck_during_mission_gps_height(vehicle: Any) -> None:
    vehicle(_failsafe_case("SENSOR_BARO", "STUCK", HEIGHT_GPS, 90, 90))


# -- test_multicopter_failure_injection.cpp ------------------------------------------------


async def _inject_expecting_disabled(t: Tester) -> None:
    from mavsdk.asyncio.plugins.failure import FailureError, FailureResult, FailureType
    from mavsdk.asyncio.plugins.failure import FailureUnit as Unit

    try:
        await t.failure.inject(Unit.SYSTEM_MOTOR, FailureType.OFF, 1)
        result = FailureResult.SUCCESS
    except FailureError as exc:
        result = exc.result
    t.check(result == FailureResult.DISABLED, f"failure injection refused as disabled: {result!r}")


def test_failure_injection_reject_mid_air_when_it_is_disabled(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.arm()
        await t.takeoff()
        await t.wait_until_hovering()
        await _inject_expecting_disabled(t)
        await t.execute_rtl()
        await t.wait_until_disarmed(180)

    vehicle(case)


def test_failure_injection_reject_before_arming(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await _inject_expecting_disabled(t)

    vehicle(case)


# -- test_multicopter_follow_me.cpp --------------------------------------------------------


class FollowTarget:
    """PX4's FollowTargetSimulator: a target moving north at 2 m/s, with seeded noise."""

    def __init__(self, start: tuple[float, float, float], home: Any) -> None:
        self.pos = list(start)
        self.vel = [0.0, 0.0, 0.0]
        self.home = home
        self.updates = 0

    def update(self, dt: float) -> None:
        self.vel = [2.0, 0.0, 0.0]
        self.pos = [p + v * dt for p, v in zip(self.pos, self.vel, strict=True)]
        self.updates += 1

    def noisy(self, values: list[float], std: float) -> list[float]:
        import random

        rng = random.Random(self.updates)
        return [v + rng.gauss(0.0, std) for v in values]

    def location(self, noise: bool, velocity: bool) -> Any:
        from mavsdk.asyncio.plugins.follow_me import TargetLocation

        n, e, d = self.noisy(self.pos, 1.0) if noise else self.pos
        lat, lon = LocalProjection(self.home.latitude_deg, self.home.longitude_deg).reproject(n, e)
        vel = self.noisy(self.vel, 0.1) if velocity else [math.nan] * 3
        return TargetLocation(lat, lon, d + self.home.absolute_altitude_m, *vel)


async def _follow_checks(t: Tester, config: Any, target: FollowTarget) -> None:
    drone = await t.position_ned()
    dist = math.dist(drone, target.pos)
    tol = 11.0
    rel = (await t.telemetry.position()).relative_altitude_m
    t.check(abs(rel - config.follow_height_m) <= 1.5, f"follow height ({rel:.1f} m)")
    t.check(abs(dist - config.follow_distance_m) <= tol, f"follow distance ({dist:.1f} m)")
    angle = math.radians(config.follow_angle_deg)
    want = (config.follow_distance_m * math.cos(angle), config.follow_distance_m * math.sin(angle))
    off = (drone[0] - target.pos[0], drone[1] - target.pos[1])
    t.check(abs(off[0] - want[0]) < tol and abs(off[1] - want[1]) < tol, f"follow angle {off}")


async def _follow_start(t: Tester) -> None:
    await t.wait_until_ready()
    await t.store_home()
    await t.arm()
    await t.set_takeoff_altitude(10.0)
    await t.takeoff()
    await t.wait_until_hovering()


def _straight_line(stream_velocity: bool) -> Callable[[Tester], Awaitable[None]]:
    async def case(t: Tester) -> None:
        from mavsdk.asyncio.plugins.follow_me import Config

        await _follow_start(t)
        target = FollowTarget(await t.position_ned(), t.home)
        config = Config(
            follow_height_m=10.0,
            follow_distance_m=8.0,
            follow_angle_deg=0.0,
            max_tangential_vel_m_s=15.0,
        )
        await t.sleep_for(1)
        t.check(await _succeeds(t.follow_me.start()), "follow me started")
        await t.sleep_for(1)
        moving = checks = False
        for i in range(75):
            if i == 5:
                config.follow_angle_deg, checks = 180.0, False
                t.check(await _succeeds(t.follow_me.set_config(config)), "config")
            elif 5 < i < 15:
                moving = True
            elif 15 <= i < 20 or 30 <= i < 35 or 45 <= i < 55 or 65 <= i < 75:
                checks = True
            elif i in (20, 35, 55):
                config.follow_angle_deg = {20: 0.0, 35: 45.0, 55: -45.0}[i]
                checks = False
                t.check(await _succeeds(t.follow_me.set_config(config)), "config")
            if moving:
                target.update(1.0)
            if checks:
                await _follow_checks(t, config, target)
            location = target.location(noise=True, velocity=stream_velocity)
            t.check(await _succeeds(t.follow_me.set_target_location(location)), "target")
            await t.sleep_for(1)
        t.check(await _succeeds(t.follow_me.stop()), "follow me stopped")
        await t.land()
        await t.wait_until_disarmed(300)

    return case


def test_follow_target_position_streaming(vehicle: Any) -> None:
    vehicle(_straight_line(stream_velocity=False))


def test_follow_target_position_and_velocity_streaming(vehicle: Any) -> None:
    vehicle(_straight_line(stream_velocity=True))


def test_follow_target_velocity_streaming_only(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        from mavsdk.asyncio.plugins.follow_me import Config, TargetLocation

        await _follow_start(t)
        config = Config(follow_angle_deg=180.0)
        t.check(await _succeeds(t.follow_me.set_config(config)), "config")
        await t.sleep_for(1)
        t.check(await _succeeds(t.follow_me.start()), "follow me started")
        await t.sleep_for(1)
        start = await t.position_ned()
        for _ in range(15):
            location = TargetLocation(math.nan, math.nan, math.nan, 2.0, 1.0, 0.5)
            t.check(await _succeeds(t.follow_me.set_target_location(location)), "target")
            await t.sleep_for(1)
        moved = math.dist(start, await t.position_ned())
        t.check(moved < 4.0, f"stayed put ({moved:.1f} m)")
        await t.land()
        await t.wait_until_disarmed(300)
        await t.check_home_within(1.0)

    vehicle(case)


def test_follow_target_rc_adjustment(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        from mavsdk.asyncio.plugins.follow_me import Config

        await _follow_start(t)
        target = FollowTarget(await t.position_ned(), t.home)
        config = Config(follow_height_m=10.0, follow_distance_m=10.0, follow_angle_deg=0.0)
        t.check(await _succeeds(t.follow_me.set_config(config)), "config")
        location = target.location(noise=False, velocity=False)
        target_pos = await t.position_ned()
        t.check(await _succeeds(t.follow_me.start()), "follow me started")
        initial = target_pos
        rate = 50
        for i in range(60 * rate + 1):
            await _succeeds(t.follow_me.set_target_location(location))  # unchecked in PX4's
            pos = await t.position_ned()
            x, z = 0.0, 0.5
            if i == 5 * rate:
                initial = pos
            elif 5 * rate < i < 8 * rate:
                z = 1.0  # raise the follow height
            elif i == 10 * rate:
                up = -(pos[2] - initial[2])
                t.check(up > 1.5 * 3.0 * 0.5, f"follow height raised ({up:.1f} m)")
            elif 10 * rate < i < 13 * rate:
                x = 1.0  # lengthen the follow distance
            elif i == 15 * rate:
                away = pos[0] - target_pos[0]
                t.check(away > 10.0 + 2.0 * 3.0 * 0.5, f"follow distance lengthened ({away:.1f})")
            await _succeeds(t.manual.set_manual_control_input(x, 0.0, z, 0.0))
            await t.sleep_for(1 / rate)
        await t.land()
        await t.wait_until_disarmed(300)

    vehicle(case)


# -- test_multicopter_goto.cpp -------------------------------------------------------------

AUTO, LOITER, GOTO = 4, 3, 21  # PX4 custom main mode, its hold and goto sub modes


async def _goto_start(t: Tester) -> None:
    await t.wait_until_ready()
    await t.store_home()
    await t.set_takeoff_altitude(10.0)
    await t.sleep_for(1)
    await t.arm()
    await t.takeoff()
    await t.wait_until_hovering()
    await t.wait_until_altitude(10.0, 15, 0.5)
    await t.sleep_for(2)


async def _reposition(
    t: Tester, n: float, e: float, change_mode: bool = True, alt: float | None = None
) -> None:
    import json

    from mavsdk.asyncio.plugins.mavlink_direct import MavlinkMessage

    proj = await t.projection()
    lat, lon = proj.reproject(n, e)
    home = await t.telemetry.home()
    fields = {
        "target_system": t.sysid,
        "target_component": 1,
        "frame": 5,  # MAV_FRAME_GLOBAL_INT
        "command": 192,  # MAV_CMD_DO_REPOSITION
        "current": 0,
        "autocontinue": 0,
        "param1": -1.0,
        "param2": 1.0 if change_mode else 0.0,  # MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        "param3": 0.0,
        "param4": math.nan,
        "x": round(lat * 1e7),
        "y": round(lon * 1e7),
        "z": home.absolute_altitude_m + 10.0 if alt is None else alt,
    }
    message = MavlinkMessage(
        "COMMAND_INT", 245, 190, t.sysid, 1, json.dumps(fields).replace("NaN", "null")
    )
    t.check(await _succeeds(t.direct.send_message(message)), "DO_REPOSITION sent")


async def _nav_state(t: Tester, main: int, sub: int, timeout: float) -> None:
    async def matches() -> bool:
        cm = t.custom_mode
        return (cm >> 16) & 0xFF == main and (cm >> 24) & 0xFF == sub

    await t.poll(matches, timeout, f"custom mode {main}.{sub}")


async def _reaches(t: Tester, target: tuple[float, float], radius: float, timeout: float) -> None:
    async def there() -> bool:
        p = await t.position_ned()
        return math.hypot(p[0] - target[0], p[1] - target[1]) <= radius

    await t.poll(there, timeout, f"within {radius} m of {target}")


async def _watch(
    t: Tester, seconds: float, ok: Callable[[tuple[float, ...]], bool], what: str
) -> None:
    end = t.now + seconds
    while t.now < end:
        p = await t.position_ned()
        t.check(ok(p), what)
        await t.sleep_for(0.1)


def test_goto_reposition_flies_to_and_holds_at_the_target(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await _goto_start(t)
        await _reposition(t, 50.0, 0.0)
        await _nav_state(t, AUTO, GOTO, 5)
        await _reaches(t, (50.0, 0.0), 2.0, 60)
        await _watch(t, 10, lambda p: math.hypot(p[0] - 50.0, p[1]) <= 2.0, "holds at target")

    vehicle(case)


def test_goto_pausing_mid_reposition_switches_to_hold(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await _goto_start(t)
        hold = await t.position_ned()
        await _reposition(t, 200.0, 0.0)
        await _nav_state(t, AUTO, GOTO, 5)
        await t.sleep_for(3)
        pause = await t.position_ned()
        t.check(await _succeeds(t.action.hold()), "hold")
        await _nav_state(t, AUTO, LOITER, 5)
        at_pause = math.hypot(pause[0] - hold[0], pause[1] - hold[1])
        await _watch(
            t,
            10,
            lambda p: math.hypot(p[0] - hold[0], p[1] - hold[1]) > at_pause - 2.0,
            "never back at the hold point",
        )
        await _watch(
            t, 5, lambda p: math.hypot(p[0] - pause[0], p[1] - pause[1]) <= 15.0, "near pause"
        )

    vehicle(case)


def test_goto_in_place_reposition_while_in_hold(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await _goto_start(t)
        await _nav_state(t, AUTO, LOITER, 5)
        await _reposition(t, 30.0, 0.0, change_mode=False)
        await _reaches(t, (30.0, 0.0), 2.0, 60)
        await _nav_state(t, AUTO, LOITER, 1)

    vehicle(case)


def test_goto_reposition_at_an_altitude_from_ground_truth(vehicle: Any) -> None:
    # The in-place case with its altitude from the ground truth of home, as a user's own
    # test may take it: the world's truth is AMSL, as HOME_POSITION is (a truth sent above
    # home had real PX4 descend to land where it stood).
    async def case(t: Tester) -> None:
        await _goto_start(t)
        home = await t.telemetry.home()
        t.check(
            abs(t.home.absolute_altitude_m - home.absolute_altitude_m) < 1.0,
            f"ground truth at home {t.home.absolute_altitude_m:.1f} m AMSL, "
            f"home {home.absolute_altitude_m:.1f} m",
        )
        await _reposition(t, 30.0, 0.0, change_mode=False, alt=t.home.absolute_altitude_m + 10)
        await _reaches(t, (30.0, 0.0), 2.0, 60)
        await _watch(t, 3, lambda p: abs(-p[2] - 10.0) < 1.5, "holds 10 m up")

    vehicle(case)


def test_goto_speed_change_while_flying_is_applied(vehicle: Any) -> None:
    async def case(t: Tester) -> None:
        await _goto_start(t)
        await _reposition(t, 200.0, 0.0)
        await _nav_state(t, AUTO, GOTO, 5)
        await t.sleep_for(5)
        t.check(await _succeeds(t.action.set_current_speed(2.0)), "speed change")
        await t.sleep_for(4)

        async def slow() -> None:
            end = t.now + 5
            while t.now < end:
                v = (await t.telemetry.position_velocity_ned()).velocity
                h = math.hypot(v.north_m_s, v.east_m_s)
                t.check(h <= 2.5, f"horizontal speed {h:.1f} <= 2.5 m/s")
                await t.sleep_for(0.1)

        await slow()
        await _nav_state(t, AUTO, GOTO, 1)

    vehicle(case)


# -- test_multicopter_rtl.cpp (after v1.15) ------------------------------------------------

RALLY_POINT = 5100  # MAV_CMD_NAV_RALLY_POINT
FRAME_GLOBAL_RELATIVE_ALT = 3
FRAME_GLOBAL_RELATIVE_ALT_INT = 6


def _raw_item(
    seq: int,
    command: int,
    frame: int,
    p1: float,
    p2: float,
    x: int,
    y: int,
    z: float,
    mission_type: int = 0,
) -> Any:
    from mavsdk.asyncio.plugins.mission_raw import MissionItem

    return MissionItem(
        seq,
        frame,
        command,
        int(seq == 0),
        1 if mission_type == 0 else 0,
        p1,
        p2,
        0.0,
        0.0,
        x,
        y,
        z,
        mission_type,
    )


async def _global(t: Tester, north: float, east: float) -> tuple[int, int]:
    lat, lon = (await t.projection()).reproject(north, east)
    return round(lat * 1e7), round(lon * 1e7)


def test_rtl_to_a_rally_point_when_home_is_not_the_closest(vehicle: Any) -> None:
    from mavsdk.asyncio.plugins.offboard import PositionNedYaw

    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        await t.store_home()
        await t.set_param_int("RTL_TYPE", 6)
        # The rally point lies between the vehicle and home: it is the closer one.
        rally = (300.0, 0.0)
        x, y = await _global(t, *rally)
        item = _raw_item(0, RALLY_POINT, FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, x, y, 0.0, 2)
        if not await _succeeds(t.mission_raw.upload_rally_points([item])):
            raise Failed("rally point upload")
        await t.arm()
        await t.takeoff()
        await t.wait_until_hovering()
        await t.offboard_goto(PositionNedYaw(400.0, 0.0, -20.0, 0.0), 5.0, 60)
        await t.execute_rtl()
        await t.wait_until_disarmed(150)
        # From the home stored before the flight, as PX4's tester: PX4 moves its home to
        # where it landed once disarmed there.
        lat, lon = LocalProjection(t.home.latitude_deg, t.home.longitude_deg).reproject(*rally)
        truth = await t.telemetry.ground_truth()
        n, e = LocalProjection(lat, lon).project(truth.latitude_deg, truth.longitude_deg)
        t.check(math.hypot(n, e) < 5.0, f"landed at the rally point ({math.hypot(n, e):.1f} m)")
        await t.check_home_not_within(20.0)

    vehicle(case)


# -- test_multicopter_mission_do_jump.cpp (after v1.15) ------------------------------------

MISSION_DO_JUMP, FRAME_MISSION = 177, 2
NAV_TAKEOFF, NAV_WAYPOINT, NAV_LAND = 22, 16, 21


def test_mission_with_an_external_set_current_onto_a_do_jump_item(vehicle: Any) -> None:
    import json

    from mavsdk.asyncio.plugins.mavlink_direct import MavlinkMessage

    async def case(t: Tester) -> None:
        await t.wait_until_ready()
        leg, alt, rel = 100.0, 15.0, FRAME_GLOBAL_RELATIVE_ALT_INT
        jump = 3
        items = []
        for seq, command, n, e, z in (
            (0, NAV_TAKEOFF, 0.0, 0.0, alt),
            (1, NAV_WAYPOINT, leg, 0.0, alt),
            (2, NAV_WAYPOINT, leg, leg, alt),
            (4, NAV_WAYPOINT, 0.0, leg, alt),
            (5, NAV_LAND, 0.0, 0.0, 0.0),
        ):
            items.append(_raw_item(seq, command, rel, 0.0, 0.0, *await _global(t, n, e), z))
        items.insert(jump, _raw_item(jump, MISSION_DO_JUMP, FRAME_MISSION, 1.0, 1.0, 0, 0, 0.0))
        if not await _succeeds(t.mission_raw.upload_mission(items)):
            raise Failed("mission upload")
        await t.sleep_for(1)
        await t.arm()
        if not await _succeeds(t.mission_raw.start_mission()):
            raise Failed("mission start")

        async def reached() -> bool:
            return bool((await t.mission_raw.mission_progress()).current >= 2)

        await t.poll(reached, 60, "mission item 2")
        # One MISSION_SET_CURRENT onto the DO_JUMP, fire and forget, as a ground station's click.
        fields = {"target_system": t.sysid, "target_component": 1, "seq": jump}
        message = MavlinkMessage("MISSION_SET_CURRENT", 245, 190, t.sysid, 1, json.dumps(fields))
        t.check(await _succeeds(t.direct.send_message(message)), "MISSION_SET_CURRENT sent")
        await t.wait_until_disarmed(240)

    vehicle(case)
