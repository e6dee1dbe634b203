"""A stand-in for ArduPilot SITL's JSON physics client, for tests that need no firmware.

Run as ``standin.py BEHAVIOUR ARDUPILOT-ARGS...`` (a fake ``bin/arducopter`` execs it). It
parses the command line multicosim gives ArduPilot, connects its MAVLink link as ArduPilot
does (``--serial0 tcpclient:HOST:PORT``) and steps like ArduPilot's JSON backend: one 40-byte
servo packet per frame, blocking for the JSON answer, resending after a second without one.
What it receives is written to ``standin.jsonl`` in its working directory; it leaves a
``logs/00000001.BIN`` there as ArduPilot leaves its DataFlash log. BEHAVIOUR:

``exit``      print a bind failure and exit 1 before any packet;
``silent``    connect nothing, send nothing, sleep;
``climb``     full throttle on four motors (1 HEARTBEAT per 100 frames, uplink logged);
``resend``    as climb, and frame 20 is sent twice;
``restart``   as climb, but the frame count starts again from 0 after frame 50;
``crash``     exit 7 after frame 50;
``mute``      step, but never speak MAVLink.
"""

from __future__ import annotations

import json
import socket
import struct
import sys
import time
from pathlib import Path

from pymavlink.dialects.v20 import common


def main() -> int:
    behaviour, args = sys.argv[1], sys.argv[2:]
    print(f"stand-in ArduPilot ({behaviour}): {' '.join(args)}", flush=True)
    opts = {key: args[i + 1] for i, key in enumerate(args[:-1]) if key.startswith("--")}
    host = opts["--sim-address"]
    instance = next(int(a[2:]) for a in args if a.startswith("-I"))
    _, link_host, link_port = opts["--serial0"].split(":")
    if behaviour == "exit":
        print("SITL: socket bind failed on RC in port : 5501 - Address already in use")
        print("Aborting launch...", flush=True)
        return 1
    if behaviour == "silent":
        print("stand-in: waiting for nothing", flush=True)
        time.sleep(120)
        return 0
    # As ArduPilot does: its DataFlash log in logs/ of its working directory.
    Path("logs").mkdir(exist_ok=True)
    Path("logs", "00000001.BIN").write_bytes(b"stand-in DataFlash log")
    link = socket.create_connection((link_host, int(link_port)), timeout=5)
    link.setblocking(False)
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    physics = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    physics.settimeout(1.0)
    target = (host, 9002 + 10 * instance)
    log = open("standin.jsonl", "w")  # noqa: SIM115 - open until the process ends
    count = 0
    resent = False

    def exchange(frame: int) -> None:
        packet = struct.pack("<HHI16H", 18458, 400, frame, *([2000] * 4 + [0] * 12))
        while True:
            physics.sendto(packet, target)
            try:
                data = physics.recv(4096)
            except TimeoutError:
                print("No JSON sensor message received, resending servos", flush=True)
                continue
            line = data.decode().strip()
            log.write(json.dumps({"frame": frame, "state": json.loads(line), "raw": line}) + "\n")
            return

    while True:
        if behaviour == "crash" and count == 50:
            print("stand-in: crashing on purpose", flush=True)
            return 7
        if behaviour == "restart" and count == 51:
            print("stand-in: rebooting", flush=True)
            count = 0
            behaviour = "climb"
        exchange(count)
        if behaviour == "resend" and count == 20 and not resent:
            resent = True
            exchange(count)
        if count % 100 == 0 and behaviour != "mute":
            link.sendall(mav.heartbeat_encode(2, 3, 0, 0, 0).pack(mav))
            try:
                uplink = link.recv(65536)
            except BlockingIOError:
                uplink = b""
            for m in mav.parse_buffer(uplink) or ():
                log.write(json.dumps({"uplink": m.get_type()}) + "\n")
        log.flush()
        count += 1


if __name__ == "__main__":
    sys.exit(main())
