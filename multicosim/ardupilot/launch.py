"""Real ArduPilot SITL: where it comes from, and starting it isolated, on our world.

Where ArduPilot comes from is a [`SITL`][multicosim.ardupilot.launch.SITL]: a directory with
``bin/arducopter``, ``bin/ardurover`` and ``params/`` (ArduPilot's default parameter files, as its
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
* the parameters a user sets for our frame (``_frames``) and the simulation's
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
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from ..core.errors import ConfigurationError, NodeStartError
from ..core.geo import Home
from ..core.interfaces import Component, Node
from ..mavlink.params import PARAM_NAME
from ..placement import Endpoint, Placement, ProgramSpec
from ..placement.firmware import (
    FirmwareNodes,
    ProgramNode,
    check_first_instance,
    launch,
    param_value,
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
    "ArduPilotLaunch",
    "ArduPilotNodes",
    "Vehicle",
    "claim_instance",
    "image_of",
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
    """Real ArduPilot SITL as the firmware: ``ardupilot.ArduCopter(firmware=SITL(...))``.

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


class ArduPilotNodes(FirmwareNodes):
    """ArduPilot's program with its bridge: stopped as one, in reverse start order."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.bridge: JsonBridge | None = None

    def flight_logs(self, into: Path) -> list[Path]:
        """ArduPilot's DataFlash logs (``logs/*.BIN``), copied out of a container into ``into``."""
        return self.files("logs", ".BIN", into)

    def stop(self) -> None:
        """Stop ArduPilot (answering its servo packets meanwhile, so that it can), then the rest.

        ArduPilot handles SIGTERM between physics steps, finishing its DataFlash log; while
        it waits for an answer it cannot, so the bridge keeps answering until it is gone.
        """
        bridge, process = self.bridge, self.program
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


class ArduPilotLaunch:
    """ArduPilot for the firmware launcher (``multicosim.placement.firmware.launch``).

    Claims an instance (its physics port bound) where ArduPilot shares this machine's ports,
    or instance 0 on a network of its own; starts the JSON bridge in this process; runs
    ArduPilot (through the guard, on this machine) in a fresh working directory, or its image.
    """

    waiting_for = "send a servo packet to its simulator"

    def __init__(
        self,
        sitl: SITL,
        vehicle: Vehicle,
        nodes: ArduPilotNodes,
        *,
        period: float,
        home: Home,
        params: Mapping[str, float],
        truth: str,
        servos: str,
        uplink: str,
        downlink: str,
    ) -> None:
        self.sitl = sitl
        self.vehicle = vehicle
        self.nodes = nodes
        self.name = nodes.name
        self.start_timeout = sitl.start_timeout
        self._period = period
        self._home = home
        self._params = params
        self._topics = {"truth": truth, "servos": servos, "uplink": uplink, "downlink": downlink}
        self._sockets: list[socket.socket] = []
        self.instance = 0
        self.bridge: JsonBridge | None = None

    def claim(self, endpoint: Endpoint) -> int:
        """Instance 0 on a private network; else the first free instance from the SITL's."""
        host = endpoint.host
        if endpoint.private:
            self.instance, physics = 0, _bind_udp(host, SIM_PORT)
        else:
            self.instance, physics = claim_instance(host, first=self.sitl.first_instance)
        self._sockets.append(physics)
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._sockets.append(listener)
        listener.bind((host, 0))
        listener.listen(4)
        return self.instance

    def bridges(self, endpoint: Endpoint) -> list[tuple[str, Component[Any, Node]]]:
        """The JSON physics bridge (it also carries ArduPilot's MAVLink link)."""
        from ..local import InProcessComponent

        physics, listener = self._sockets
        topics = self._topics

        def json_bridge() -> JsonBridge:
            self.bridge = JsonBridge(
                name=self.name,
                period=self._period,
                physics=physics,
                mavlink=listener,
                truth=topics["truth"],
                servos=topics["servos"],
                uplink=topics["uplink"],
                downlink=topics["downlink"],
                lockstep_timeout=self.sitl.lockstep_timeout,
            )
            self.nodes.bridge = self.bridge
            return self.bridge

        return [(f"{self.name}.json", InProcessComponent(json_bridge, f"{self.name}.json"))]

    def program(self, endpoint: Endpoint, workdir: Path) -> ProgramSpec:
        """ArduPilot in ``workdir`` through the guard (a directory), or its image."""
        assert self.bridge is not None
        sitl, port = self.sitl, self.bridge.mavlink_port
        # Instance N is system N + 1, as ArduPilot's multi-vehicle SITL numbers them (a
        # system id the user sets wins).
        params = {"SYSID_THISMAV": float(self.instance + 1), **self._params}
        command = None
        if sitl.directory is not None:
            overlay = write_overlay(workdir, params)
            args = launch_command(
                sitl.binary(self.vehicle),
                [sitl.defaults(self.vehicle), overlay],
                host=endpoint.host,
                instance=self.instance,
                home=self._home,
                mavlink_port=port,
            )
            # Through the guard: ArduPilot does not outlive this process (see _guard.py).
            command = [sys.executable, "-I", str(GUARD), *args]
        image_command = container_command(
            vehicle=self.vehicle,
            sim_host=endpoint.host,
            mavlink_port=port,
            home=self._home,
            params=params,
        )
        return ProgramSpec(
            name=self.name,
            command=command,
            cwd=str(workdir),
            image=image_of(sitl),
            image_command=image_command,
            image_workdir=CONTAINER_WORKDIR,
        )

    def started(self, program: ProgramNode, endpoint: Endpoint) -> None:
        """Watch ArduPilot; on a shared machine, take traffic only from its own sockets."""
        assert self.bridge is not None
        self.bridge.watch = program
        if not endpoint.private and program.pid is not None:
            self.bridge.peer_check = _owned_by(program.pid)

    def ready(self) -> bool:
        """Whether ArduPilot has sent its first servo packet."""
        return self.bridge is not None and self.bridge.poll_started()

    def release(self) -> None:
        """Close the claimed sockets unless the bridge took them."""
        if self.bridge is None:
            for sock in self._sockets:
                sock.close()


def image_of(sitl: SITL) -> str | Callable[[], str] | None:
    """The ArduPilot image a container runs: the SITL's, or one built from its directory
    (on first use; a build whose inputs did not change is skipped)."""
    if sitl.image is not None or sitl.directory is None:
        return sitl.image
    directory = sitl.path

    def build() -> str:
        from .image import build_image

        return build_image(directory)

    return build


def start_ardupilot(
    sitl: SITL,
    vehicle: Vehicle,
    placement: Placement,
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
    """Start ArduPilot where ``placement`` runs programs, with its bridge in this process.

    Returns once ArduPilot has sent its first servo packet; it then waits, in lockstep, for
    the simulation's clock. Every part started is stopped again if a later one fails.
    """
    nodes = ArduPilotNodes(name)
    ardupilot = ArduPilotLaunch(
        sitl,
        vehicle,
        nodes,
        period=period,
        home=home,
        params=params,
        truth=truth,
        servos=servos,
        uplink=uplink,
        downlink=downlink,
    )
    launch(ardupilot, placement, environment, nodes)
    return nodes


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
