"""Real PX4 holding a 10 m takeoff in our world: how well its estimator takes our sensors.

Real PX4 SITL (``multicosim px4 sitl --px4-binary``, medium fidelity, lockstep) takes off to
MIS_TAKEOFF_ALT = 10 m and holds for 60 simulated seconds; a pymavlink ground station on its
API link records, on PX4's clock, the altitude PX4 estimates (what PX4's MAVSDK case checks)
and its attitude. From PX4's own ULog (pyulog) come the estimator's innovation test ratios
(``estimator_status``: height, position, velocity, magnetometer) over the same 60 s.

Reported: the mean altitude and its largest and mean error from 10 m, the attitude jitter
(standard deviation of roll and pitch), and each test ratio's mean and maximum (1 is the
gate: the estimator rejects a measurement above it). ``bench/results/hold.json`` keeps the
measurement from before PX4's clock in the HIL stream started a second in and the sensors
took PX4's Gazebo noise (``before``) beside the latest run.

Needs a PX4 SITL binary: ``--px4-binary PATH`` or ``MCS_PX4_BINARY``.
Usage: ``python bench/bench_hold.py``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import RESULTS, write_result

TARGET_ALT = 10.0  # m
HOLD = 60.0  # simulated seconds
QUICK_HOLD = 10.0  # simulated seconds, with --quick
SPEED = 6.0
RATIOS = ("hgt_test_ratio", "pos_test_ratio", "vel_test_ratio", "mag_test_ratio")
WALL_LIMIT = 900.0  # s


class Station:
    """A pymavlink ground station on real PX4's API link, on PX4's clock (time_boot_ms)."""

    def __init__(self, port: int, system: int) -> None:
        from pymavlink import mavutil

        self.conn: Any = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=245, source_component=190, dialect="common"
        )
        self.system = system
        self.ms = 0
        self.mode: tuple[int, int, bool] = (0, 0, False)
        self.alt: float | None = None
        self.att: tuple[float, float] = (0.0, 0.0)
        self.home = False
        self._beat = 0.0
        self._deadline = time.monotonic() + WALL_LIMIT

    def pump(self) -> None:
        if time.monotonic() - self._beat > 0.5:
            self._beat = time.monotonic()
            self.conn.mav.heartbeat_send(6, 8, 0, 0, 4)
        m = self.conn.recv_match(blocking=True, timeout=0.05)
        while m is not None:
            if m.get_srcSystem() == self.system:
                t = getattr(m, "time_boot_ms", None)
                if isinstance(t, int) and t > self.ms:
                    self.ms = t
                kind = m.get_type()
                if kind == "HEARTBEAT" and m.get_srcComponent() == 1:
                    cm = m.custom_mode
                    self.mode = ((cm >> 16) & 255, (cm >> 24) & 255, bool(m.base_mode & 128))
                elif kind == "LOCAL_POSITION_NED":
                    self.alt = -m.z
                elif kind == "ATTITUDE":
                    self.att = (math.degrees(m.roll), math.degrees(m.pitch))
                elif kind == "HOME_POSITION":
                    self.home = True
            m = self.conn.recv_match(blocking=False)

    def run(self, seconds: float, until: Any = None, each: Any = None) -> bool:
        """Pump for ``seconds`` of PX4's time, or until ``until()``; call ``each()`` per read."""
        start = self.ms
        while self.ms == 0 or self.ms - start < seconds * 1000:
            if time.monotonic() > self._deadline:
                raise TimeoutError("real PX4 did not get there in time")
            self.pump()
            if start == 0:
                start = self.ms
            if each is not None and self.alt is not None:
                each()
            if until is not None and until():
                return True
        return False

    def command(self, cmd: int, *params: float) -> None:
        p = [*params, *[0.0] * (7 - len(params))]
        self.conn.mav.command_long_send(self.system, 1, cmd, 0, *p)


def measure(binary: str, hold: float = HOLD) -> dict[str, Any]:
    """Take off, hold ``hold`` s (60): the numbers (see the module)."""
    with tempfile.TemporaryFile() as out:
        cmd = [sys.executable, "-m", "multicosim", "px4", "sitl", "--px4-binary", binary]
        proc = subprocess.Popen(
            [*cmd, "--speed", str(SPEED), "--gcs-port", "0"],
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        try:
            found = None
            deadline = time.monotonic() + 120
            while found is None and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.2)
                out.seek(0)
                found = re.search(
                    r"SITL instance (\d+) .*logs: ([^)]+)\)", out.read().decode(errors="replace")
                )
            if found is None:
                raise RuntimeError("real PX4 did not start")
            instance, logs = int(found.group(1)), Path(found.group(2))
            return _fly(Station(14540 + instance, instance + 1), logs, hold)
        finally:
            os.killpg(proc.pid, signal.SIGTERM)  # PX4 too: it is in the group
            proc.wait(30)


def _fly(s: Station, logs: Path, hold: float) -> dict[str, Any]:
    s.command(512, 242)  # REQUEST_MESSAGE HOME_POSITION
    s.run(60, lambda: s.home)
    s.conn.mav.param_set_send(s.system, 1, b"MIS_TAKEOFF_ALT", TARGET_ALT, 9)
    s.run(2)
    for _ in range(30):
        s.command(400, 1)  # arm
        if s.run(2, lambda: s.mode[2]):
            break
    s.command(22, 0, 0, 0, math.nan, math.nan, math.nan, math.nan)  # takeoff
    s.run(40, lambda: s.mode[:2] == (4, 3) and s.alt is not None and s.alt > TARGET_ALT - 1)
    s.run(10)  # settle
    alts: list[float] = []
    rolls: list[float] = []
    pitches: list[float] = []
    t0 = s.ms / 1000

    def sample() -> None:
        assert s.alt is not None
        alts.append(s.alt)
        rolls.append(s.att[0])
        pitches.append(s.att[1])

    s.run(hold, each=sample)
    s.command(21)  # land
    s.run(90, lambda: not s.mode[2])
    s.run(3)
    errors = [abs(a - TARGET_ALT) for a in alts]
    out: dict[str, Any] = {
        "altitude_mean_m": statistics.fmean(alts),
        "error_max_m": max(errors),
        "error_mean_m": statistics.fmean(errors),
        "roll_std_deg": statistics.pstdev(rolls),
        "pitch_std_deg": statistics.pstdev(pitches),
    }
    from pyulog import ULog

    ulogs = sorted(logs.glob("**/*.ulg"), key=lambda p: p.stat().st_mtime)
    data = ULog(str(ulogs[-1]), ["estimator_status"]).get_dataset("estimator_status").data
    inside = [i for i, t in enumerate(data["timestamp"]) if t0 <= t * 1e-6 <= t0 + hold]
    for name in RATIOS:
        values = [float(data[name][i]) for i in inside]
        out[name] = {"mean": statistics.fmean(values), "max": max(values)}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--px4-binary", default=os.environ.get("MCS_PX4_BINARY"))
    parser.add_argument("--output", type=Path, default=None)
    parser.add_argument(
        "--quick", action="store_true", help=f"hold {QUICK_HOLD:g} s (does it still run?)"
    )
    args = parser.parse_args(argv)
    if not args.px4_binary:
        reason = "no PX4 SITL binary (--px4-binary or MCS_PX4_BINARY)"
        print(f"skipped: {reason}")
        write_result("hold", {"skipped": reason}, args.output)
        return 0
    previous = RESULTS / "hold.json"
    before = json.loads(previous.read_text()).get("before") if previous.exists() else None
    after = measure(args.px4_binary, QUICK_HOLD if args.quick else HOLD)
    for label, r in (("before", before), ("after", after)):
        if r is None:
            continue
        ratios = ", ".join(f"{n} {r[n]['mean']:.3f}/{r[n]['max']:.3f}" for n in RATIOS)
        print(
            f"{label}: altitude {r['altitude_mean_m']:.3f} m (error max {r['error_max_m']:.3f} m,"
            f" mean {r['error_mean_m']:.3f} m); roll/pitch std {r['roll_std_deg']:.3f}/"
            f"{r['pitch_std_deg']:.3f} deg; test ratios mean/max: {ratios}"
        )
    path = write_result("hold", {"before": before, "after": after}, args.output)
    print(f"wrote {path.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
