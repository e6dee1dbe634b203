"""Record real PX4 SITL's MAVLink answers into multicosim/px4/data/px4-<version>.json.

    python scripts/record_px4.py ../shared/px4-sitl/bin/px4

Runs ``multicosim px4 sitl --px4-binary BINARY`` (real PX4 flying our MuJoCo world, its own
MAVLink links), asks it every question of :func:`multicosim.px4.conformance.record` on its
API link (on the ground, then flying: takeoff, DO_REPOSITION, offboard), reads its parameter
metadata over MAVLink FTP, and writes the answers. The built-in autopilot takes its parameter
table and stream rates from that file, and tests/px4/test_conformance.py checks its answers
against it. A stalled or exited PX4 ends the recording with an error and PX4's output; PX4
is stopped whatever happens (Ctrl-C and SIGTERM included).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from multicosim.px4 import conformance
from multicosim.px4.standalone import paced_params

API_PORT = 14540  # where PX4's API link sends, plus its instance number
PX4_API_PORT = 14580  # where it listens


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("binary", help="PX4 SITL binary (bin/px4 with etc/ beside bin/)")
    parser.add_argument("--speed", type=float, default=4.0, help="simulated s per wall s")
    parser.add_argument(
        "--out",
        default=str(
            Path(conformance.__file__).parent / "data" / f"px4-{conformance.PX4_VERSION}.json"
        ),
    )
    parser.add_argument("--log", default=None, help="keep the SITL's output in this file")
    args = parser.parse_args()
    # A SIGTERM (a time limit's) unwinds like Ctrl-C, so that PX4 is stopped below.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    started = time.monotonic()
    with open(args.log, "w+b") if args.log else tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "multicosim",
                "px4",
                "sitl",
                "--px4-binary",
                args.binary,
                "--speed",
                str(args.speed),
            ],
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        try:
            instance = _instance(proc, log)
            data = conformance.record(
                API_PORT + instance,
                peer=PX4_API_PORT + instance,
                metadata=True,
                alive=lambda: proc.poll() is None,
            )
        except BaseException:
            log.seek(0)
            print(log.read().decode(errors="replace")[-3000:], file=sys.stderr)
            raise
        finally:
            _stop(proc)
    # PX4's SITL start-up numbers the vehicle after its instance (etc/init.d-posix/rcS:
    # MAV_SYS_ID and UXRCE_DDS_KEY are instance + 1): the file keeps a lone PX4's, instance 0's.
    # (_HASH_CHECK, ground stations' cache key over all values, stays the instance's.)
    for name in ("MAV_SYS_ID", "UXRCE_DDS_KEY"):
        data["params"][name]["value"] = 1
    # Paced at --speed, PX4 reports the loss timeouts its start-up lengthens for that speed
    # (paced_params); the file keeps what it has at real time, its defaults.
    for name in paced_params(args.speed):
        data["params"][name]["value"] = data["params"][name]["default"]
    data = {"px4": conformance.PX4_VERSION, **data}
    Path(args.out).write_text(json.dumps(data, indent=1, sort_keys=False) + "\n")
    print(
        f"wrote {args.out}: {data['count']} parameters, {len(data['streams'])} streams "
        f"({time.monotonic() - started:.0f} s)"
    )
    return 0


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """Stop the SITL and everything it started (its process group), killed if it lingers."""
    with contextlib.suppress(ProcessLookupError):  # it may have exited on its own
        os.killpg(proc.pid, signal.SIGTERM)
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(30)
    with contextlib.suppress(ProcessLookupError):  # what is left of its group, if anything
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(30)


def _instance(proc: subprocess.Popen[bytes], log: object) -> int:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        log.seek(0)  # type: ignore[attr-defined]
        text = log.read().decode(errors="replace")  # type: ignore[attr-defined]
        found = re.search(r"real PX4 SITL instance (\d+)", text)
        if found:
            return int(found.group(1))
        if proc.poll() is not None:
            raise SystemExit(f"PX4 exited ({proc.returncode}):\n{text[-2000:]}")
        time.sleep(0.2)
    raise SystemExit("PX4 did not start within 60 s")


if __name__ == "__main__":
    sys.exit(main())
