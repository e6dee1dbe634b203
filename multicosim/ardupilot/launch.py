"""Real ArduPilot SITL: where it comes from, and starting it isolated, on our world.

Where ArduPilot comes from is a :class:`SITL`: a directory with ``bin/arducopter``,
``bin/ardurover`` and ``params/`` (ArduPilot's default parameter files, as its
``Tools/autotest/default_params``), run as a local process, or an image
(``multicosim images build --ardupilot-dir DIR``) run as a container on the
simulation's network. Each ArduPilot gets:

* its own instance number N (``-I N``), claimed by binding its physics port 9002 + 10 N on
  loopback (atomic: two runs never claim one instance); an N whose usual ports (MAVLink TCP
  5760 + 10 N, RC input UDP 5501 + 10 N) another SITL holds is skipped;
* a fresh working directory in the run directory: ArduPilot writes ``eeprom.bin``,
  ``logs/`` (its DataFlash logs, ``.BIN``) and ``terrain/`` there;
* no listening port: its MAVLink link connects out to the simulation
  (``--serial0 tcpclient:HOST:PORT``, a loopback port of this process), its other serial
  ports are off (``none``), and its RC input socket is on an ephemeral port instead of
  5501 + 10 N. What ArduPilot still opens on all interfaces (that RC socket and the socket
  it sends servo packets from, both on ephemeral ports) is not answered by anyone but it;
  in a container, nothing of it is reachable beyond the simulation's own network;
* the parameters a user sets for our frame (:mod:`._frames`) and the simulation's
  (``params``), in a defaults file beside ArduPilot's own.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
import socket
import sys
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from ..core.errors import ConfigurationError, NodeStartError
from ..core.geo import Home
from ..core.interfaces import Node
from ..local import ending, mark_reported
from ..mavlink.params import PARAM_NAME
from ..mavlink.sitl import (
    SitlNodes,
    check_first_instance,
    copy_out,
    is_container_environment,
    param_value,
    run_container,
    udp_free,
)
from ._bridge import JsonBridge, PeerCheck, process_ports

if TYPE_CHECKING:
    from ..local import LocalEnvironment

__all__ = [
    "BINARIES",
    "NO_RC_RECEIVER",
    "SIM_PORT",
    "SITL",
    "ArduPilotNodes",
    "Vehicle",
    "claim_instance",
    "launch_command",
    "start_ardupilot",
]

log = logging.getLogger(__name__)

Vehicle = Literal["copter", "rover"]
BINARIES: dict[str, str] = {"copter": "arducopter", "rover": "ardurover"}
PARAM_FILES: dict[str, str] = {"copter": "copter.parm", "rover": "rover.parm"}
SIM_PORT = 9002
"""ArduPilot's JSON physics port for instance 0 (instance N sends to SIM_PORT + 10 N)."""
MAVLINK_PORT = 5760  # SERIAL0's TCP port of instance 0, + 10 N (a foreign SITL's sign)
RC_PORT = 5501  # RC input UDP port of instance 0, + 10 N (a foreign SITL's sign)
MAX_INSTANCE = 99
NO_RC_RECEIVER: dict[str, float] = {"RC_OPTIONS": 1, "FS_THR_ENABLE": 0}
"""ArduPilot ignores its RC receiver (``RC_OPTIONS`` bit 0) and so has no throttle failsafe:
the ground station flies it. Its simulated receiver is a UDP socket on all interfaces that
cannot be bound to loopback; whatever reaches it (a stray or hostile packet switching the
flight mode, say) changes nothing."""
OVERLAY = "multicosim.parm"
GUARD = Path(__file__).with_name("_guard.py")
CONTAINER_DIR = "/opt/ardupilot"
CONTAINER_WORKDIR = "/ardupilot"


@dataclasses.dataclass(frozen=True, kw_only=True)
class SITL:
    """Real ArduPilot SITL as the firmware: ``ardupilot.Copter(firmware=SITL(...))``.

    ``directory`` holds ``bin/arducopter``, ``bin/ardurover`` (ArduPilot's SITL builds) and
    ``params/copter.parm``, ``params/rover.parm`` (its default parameters). ``image`` is an
    ArduPilot image from ``multicosim images build --ardupilot-dir DIR``, for
    ``backend="docker"``; with only a directory, the docker backend builds that image.
    ``params`` are set at boot. ``start_timeout`` bounds (wall seconds) the start until
    ArduPilot's first servo packet; ``lockstep_timeout`` each physics step once it runs.
    ``first_instance`` is the lowest instance number a local run claims (the ones below stay
    free for SITLs started by hand on their usual ports).
    """

    directory: str | None = None
    image: str | None = None
    params: Mapping[str, float] = dataclasses.field(default_factory=dict)
    start_timeout: float = 60.0
    lockstep_timeout: float = 30.0
    first_instance: int = 0

    def __post_init__(self) -> None:
        if self.directory is None and self.image is None:
            raise ConfigurationError(
                "firmware_dir",
                None,
                "ArduPilot SITL's directory (bin/arducopter, bin/ardurover, params/) or an image",
            )
        if self.directory is not None:
            directory = self.directory
            if not isinstance(directory, str | os.PathLike) or not str(directory):
                raise ConfigurationError(
                    "firmware_dir", directory, "the path of ArduPilot SITL's directory"
                )
            if not Path(directory).is_dir():
                raise ConfigurationError(
                    "firmware_dir",
                    str(directory),
                    "an existing directory with bin/arducopter, bin/ardurover and params/",
                )
        if self.image is not None and (
            not isinstance(self.image, str) or not self.image.strip() or " " in self.image
        ):
            raise ConfigurationError("image", self.image, "a local image name such as 'name:tag'")
        if not isinstance(self.params, Mapping):
            raise ConfigurationError("params", self.params, "a mapping of ArduPilot name to number")
        check_params(self.params)
        for field in ("start_timeout", "lockstep_timeout"):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
                raise ConfigurationError(field, value, "a positive number of seconds")
        check_first_instance(self.first_instance, MAX_INSTANCE)

    @property
    def path(self) -> Path:
        """The directory, resolved."""
        assert self.directory is not None
        return Path(self.directory).resolve()

    def binary(self, vehicle: Vehicle) -> Path:
        """The SITL executable of ``vehicle``."""
        return self.path / "bin" / BINARIES[vehicle]

    def defaults(self, vehicle: Vehicle) -> Path:
        """ArduPilot's default parameter file of ``vehicle``."""
        return self.path / "params" / PARAM_FILES[vehicle]

    def check(self, vehicle: Vehicle) -> None:
        """Raise ConfigurationError unless the directory can run ``vehicle``."""
        if self.directory is None:
            return
        binary = self.binary(vehicle)
        if not binary.is_file():
            raise ConfigurationError(
                "firmware_dir",
                str(self.directory),
                f"a directory with bin/{BINARIES[vehicle]} (ArduPilot's SITL build of the "
                f"{vehicle}): {binary} is missing",
            )
        if not os.access(binary, os.X_OK):
            raise ConfigurationError(
                "firmware_dir",
                str(self.directory),
                f"a directory whose bin/{BINARIES[vehicle]} is executable (chmod +x {binary})",
            )
        defaults = self.defaults(vehicle)
        if not defaults.is_file():
            raise ConfigurationError(
                "firmware_dir",
                str(self.directory),
                f"a directory with params/{PARAM_FILES[vehicle]} (ArduPilot's default "
                f"parameters of the {vehicle}, from Tools/autotest/default_params): "
                f"{defaults} is missing",
            )


def check_params(params: Mapping[str, object], field: str = "params") -> None:
    """Raise ConfigurationError for a parameter name or value ArduPilot cannot take."""
    for name, value in params.items():
        if not isinstance(name, str) or not PARAM_NAME.match(name):
            raise ConfigurationError(
                field, name, "ArduPilot parameter names (upper case, at most 16 characters)"
            )
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ConfigurationError(f"{field}[{name!r}]", value, "a finite number")


# -- instances ------------------------------------------------------------------------------


def _tcp_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def _foreign(instance: int) -> bool:
    """Whether another SITL of ``instance`` holds its usual ports (its MAVLink or RC input)."""
    base = 10 * instance
    if not udp_free("0.0.0.0", RC_PORT + base):
        return True
    return not all(_tcp_free(MAVLINK_PORT + base + k) for k in range(4))


def claim_instance(host: str = "127.0.0.1", *, first: int = 0) -> tuple[int, socket.socket]:
    """A free ArduPilot instance number from ``first`` on and its physics port, bound (the
    claim)."""
    for n in range(first, MAX_INSTANCE + 1):
        if _foreign(n):
            continue
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((host, SIM_PORT + 10 * n))
        except OSError:
            sock.close()
            continue
        return n, sock
    raise NodeStartError(
        "ardupilot",
        f"no free ArduPilot instance: UDP ports {SIM_PORT}..{SIM_PORT + 10 * MAX_INSTANCE} "
        "(step 10, or another SITL's ports of the same instance) are all in use",
    )


# -- the command ----------------------------------------------------------------------------


def write_overlay(workdir: Path, params: Mapping[str, float]) -> Path:
    """ArduPilot's defaults file with ``params`` (after its own: these win)."""
    workdir.mkdir(parents=True, exist_ok=True)
    lines = ["# multicosim: parameters for this run"]
    lines += [f"{name} {param_value(value)}" for name, value in params.items()]
    path = workdir / OVERLAY
    path.write_text("\n".join(lines) + "\n")
    return path


def launch_command(
    binary: str | Path,
    defaults: list[str | Path],
    *,
    host: str,
    instance: int,
    home: Home,
    mavlink_port: int,
) -> list[str]:
    """ArduPilot's command line: JSON physics on ``host``, MAVLink out to ``host``."""
    lat, lon, alt = home
    return [
        str(binary),
        "--model",
        f"JSON:{host}",
        "--sim-address",
        host,
        f"-I{instance}",
        "--home",
        f"{lat!r},{lon!r},{alt!r},0",
        "--defaults",
        ",".join(str(d) for d in defaults),
        # MAVLink connects out to the simulation; no port listens (0.0.0.0 by default).
        "--serial0",
        f"tcpclient:{host}:{mavlink_port}",
        "--serial1",
        "none",
        "--serial2",
        "none",
        # RC input on an ephemeral port: never the well-known 5501 + 10 N.
        "--rc-in-port",
        "0",
    ]


def exec_in_container(
    *, vehicle: Vehicle, sim_host: str, mavlink_port: int, home: Home, params: Mapping[str, float]
) -> None:
    """Write ArduPilot's defaults file in its container and become ArduPilot (never returns).

    The entry point of the ArduPilot image (``multicosim ardupilot launch``).
    """
    sitl = SITL(directory=CONTAINER_DIR)
    sitl.check(vehicle)
    workdir = Path(CONTAINER_WORKDIR)
    overlay = write_overlay(workdir, params)
    args = launch_command(
        sitl.binary(vehicle),
        [sitl.defaults(vehicle), overlay],
        host=sim_host,
        instance=0,
        home=home,
        mavlink_port=mavlink_port,
    )
    os.chdir(workdir)
    os.execv(args[0], args)


def container_command(
    *, vehicle: Vehicle, sim_host: str, mavlink_port: int, home: Home, params: Mapping[str, float]
) -> list[str]:
    """The ArduPilot image's command for ``exec_in_container``'s arguments."""
    lat, lon, alt = home
    return [
        "multicosim",
        "ardupilot",
        "launch",
        "--vehicle",
        vehicle,
        "--sim-host",
        sim_host,
        "--mavlink-port",
        str(mavlink_port),
        "--home",
        f"{lat!r},{lon!r},{alt!r}",
        "--params",
        json.dumps(dict(params)),
    ]


# -- starting it ----------------------------------------------------------------------------


def start_error(name: str, what: str, watch: Any, exit_code: int | None = None) -> NodeStartError:
    """A NodeStartError for ArduPilot with its output tail (its exit remembered as reported)."""
    if exit_code is not None:
        mark_reported(watch)
    return NodeStartError(name, what, exit_code=exit_code, log_tail=watch.log_tail())


def wait_started(bridge: JsonBridge, process: Any, name: str, timeout: float) -> None:
    """Wait for ArduPilot's first servo packet; NodeStartError with its output if none comes."""
    deadline = time.monotonic() + timeout
    while not bridge.poll_started():
        code = process.poll()
        if code is not None:
            raise start_error(
                name, f"{ending(process)} before it sent a servo packet", process, code
            )
        if time.monotonic() > deadline:
            raise start_error(
                name,
                f"sent no servo packet to its simulator (UDP port {bridge.physics_port}) "
                f"within {timeout:g} s",
                process,
            )
        time.sleep(0.01)


class ArduPilotNodes(SitlNodes):
    """ArduPilot's process or container with its bridge: stopped as one, in reverse order."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.bridge: JsonBridge | None = None

    def flight_logs(self, into: Path) -> list[Path]:
        """ArduPilot's DataFlash logs (``logs/*.BIN``), copied out of a container into ``into``."""
        container = getattr(self.process, "container", None)
        if container is not None:
            return copy_out(container, f"{CONTAINER_WORKDIR}/logs", into, ".BIN")
        if self.rootfs is None:
            return []
        return sorted((self.rootfs / "logs").glob("*.BIN"))

    def stop(self) -> None:
        """Stop ArduPilot (answering its servo packets meanwhile, so that it can), then the rest.

        ArduPilot handles SIGTERM between physics steps, finishing its DataFlash log; while
        it waits for an answer it cannot, so the bridge keeps answering until it is gone.
        """
        bridge, process = self.bridge, self.process
        done = threading.Event()
        feeder = None
        if bridge is not None and process is not None and process.poll() is None:

            def gone() -> bool:
                return done.is_set() or process.poll() is not None

            feeder = threading.Thread(
                target=bridge.idle, args=(gone, 15.0), name=f"{self.name}-stop", daemon=True
            )
            feeder.start()
        try:
            super().stop()
        finally:
            done.set()
            if feeder is not None:
                feeder.join(5.0)


def start_ardupilot(
    sitl: SITL,
    vehicle: Vehicle,
    environment: LocalEnvironment,
    *,
    name: str,
    period: float,
    home: Home,
    params: Mapping[str, float],
    truth: str,
    servos: str,
    uplink: str,
    downlink: str,
) -> ArduPilotNodes:
    """Start ArduPilot (a process, or a container in a ContainerSimulator) with its bridge.

    Returns once ArduPilot has sent its first servo packet; it then waits, in lockstep, for
    the simulation's clock. Every part started is stopped again if a later one fails.
    """
    from ..local import InProcessComponent, ProcessComponent

    group = ArduPilotNodes(name)
    container = is_container_environment(environment)
    with group.starting():
        if container:
            # Each simulation has a network of its own: ArduPilot is instance 0 in its
            # container and reaches the bridge on the network's gateway.
            host = environment.gateway  # type: ignore[attr-defined]
            instance, physics = 0, _bind_udp(host, SIM_PORT)
        else:
            host = "127.0.0.1"
            instance, physics = claim_instance(host, first=sitl.first_instance)
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            listener.bind((host, 0))
            listener.listen(4)
        except BaseException:
            listener.close()
            physics.close()
            raise
        bridge_node = InProcessComponent(
            lambda: JsonBridge(
                name=name,
                period=period,
                physics=physics,
                mavlink=listener,
                truth=truth,
                servos=servos,
                uplink=uplink,
                downlink=downlink,
                lockstep_timeout=sitl.lockstep_timeout,
            ),
            f"{name}.json",
        ).start(environment)
        group.add(f"{name}.json", bridge_node)
        bridge = bridge_node.participant
        group.bridge = bridge
        process: Any
        if container:
            process = _start_container(
                sitl,
                environment,
                name=name,
                vehicle=vehicle,
                mavlink_port=bridge.mavlink_port,
                home=home,
                params=params,
            )
        else:
            workdir = environment.run_dir / f"{name}-ardupilot"
            overlay = write_overlay(workdir, params)
            group.rootfs = workdir
            command = launch_command(
                sitl.binary(vehicle),
                [sitl.defaults(vehicle), overlay],
                host=host,
                instance=instance,
                home=home,
                mavlink_port=bridge.mavlink_port,
            )
            # Through the guard: ArduPilot does not outlive this process (see _guard.py).
            guarded = [sys.executable, "-I", str(GUARD), *command]
            process = ProcessComponent(
                guarded, name=name, cwd=str(workdir), ready="started", stop_timeout=10.0
            ).start(environment)
            bridge.peer_check = _owned_by(process.pid)
        group.add(name, process)
        group.process = process
        group.instance = instance
        bridge.watch = process
        wait_started(bridge, process, name, sitl.start_timeout)
        log.info("%s: ArduPilot instance %d is stepping its physics", name, instance)
    return group


def _owned_by(pid: int) -> PeerCheck:
    """A peer check: traffic from a loopback socket that process ``pid`` holds."""

    def check(proto: str, addr: tuple[str, int]) -> bool:
        return addr[0] == "127.0.0.1" and (proto, addr[1]) in process_ports(pid)

    return check


def _bind_udp(host: str, port: int) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise NodeStartError(
            "ardupilot", f"could not bind {host}:{port} for ArduPilot's physics: {exc}"
        ) from exc
    return sock


def _start_container(
    sitl: SITL,
    environment: Any,
    *,
    name: str,
    vehicle: Vehicle,
    mavlink_port: int,
    home: Home,
    params: Mapping[str, float],
) -> Node:
    assert sitl.image is not None
    command = container_command(
        vehicle=vehicle,
        sim_host=environment.gateway,
        mavlink_port=mavlink_port,
        home=home,
        params=params,
    )
    return run_container(environment, sitl.image, command, name)
