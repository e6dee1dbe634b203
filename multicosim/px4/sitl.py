"""Real PX4 SITL as the firmware of the PX4 scenario: the top of the fidelity ladder.

PX4's SITL build (``px4_sitl_default``) flies our MuJoCo quadrotor the way it flies Gazebo's:
its ``simulator_mavlink`` module connects to
``HilTcpBridge`` (TCP 4560 + instance, lockstep), and its
MAVLink API link is carried to the same ground station that drives our built-in autopilot
(``multicosim.mavlink.gcs``), so ``simulation.firmware.send`` flies a mission on either.

Where PX4 comes from is a [`SITL`][multicosim.px4.sitl.SITL]: a ``px4`` binary with its ``etc``
ROMFS beside it (``../shared/px4-sitl`` or a ``build/px4_sitl_default`` tree) run as a local
process, or an image (``multicosim images build --px4-dir DIR``) run as a container on the
simulation's network. Each PX4 gets:

* its own instance number (claimed by binding its simulator port; the other ports checked
  free), so parallel runs (``pytest -n 2``) never share ports, lock files or sockets;
* a fresh working directory in the run directory (PX4 keeps parameters there);
* a private ``bin`` directory first on its PATH with the ``px4-<module>`` command links its
  start-up script calls (so a bundle whose links were flattened into files still runs), and
  the ``px4-rc.params`` / ``px4-rc.mavlink`` hooks that PX4's start-up script sources from
  the PATH: our parameters, and one MAVLink link to our ground station instead of PX4's
  defaults (nothing is sent to other programs' ports).
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import fcntl
import json
import logging
import math
import os
import re
import socket
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from ..core.errors import ConfigurationError, NodeStartError
from ..core.interfaces import Component, Node
from ..mavlink.hil import Wire
from ..mavlink.params import PARAM_NAME
from ..mavlink.udp import API_PORT, GCS_PORT, Link, UdpBridge
from ..placement import Endpoint, Placement, ProgramSpec
from ..placement.firmware import (
    FirmwareNodes,
    ProgramNode,
    check_first_instance,
    launch,
    param_value,
    udp_free,
)
from ..quadrotor.topics import Topics
from .simulator import SIM_PORT, HilTcpBridge

if TYPE_CHECKING:
    from ..local import LocalEnvironment

__all__ = [
    "API_LOCAL_PORT",
    "SITL",
    "PX4Launch",
    "claim_instance",
    "image_of",
    "launch_command",
    "prepare_rootfs",
    "start_sitl",
]

log = logging.getLogger(__name__)

API_LOCAL_PORT = 14580
"""PX4 binds its API (offboard) link here, plus the instance number."""
GCS_LOCAL_PORT = 18570
"""PX4 binds its ground-station link here, plus the instance number."""
MAX_INSTANCE = 99
CONTAINER_BUNDLE = "/opt/px4"
CONTAINER_ROOTFS = "/px4"
SENSOR_RATE = 250.0  # Hz: what PX4 SITL expects of its simulator (IMU_INTEG_RATE 250)


def _bundle_of(binary: Path) -> Path:
    # bin/px4 in a bundle or in build/px4_sitl_default: the ROMFS is ../etc.
    return binary.parent.parent


@dataclasses.dataclass(frozen=True, kw_only=True)
class SITL:
    """Real PX4 SITL as the firmware: ``px4.PX4(world, fidelity="medium", firmware=SITL(...))``.

    ``binary`` is PX4's ``px4`` executable (a ``px4_sitl_default`` build, lockstep); ``etc``
    its ROMFS (default: ``etc`` beside the binary's ``bin`` directory). ``image`` is a PX4
    SITL image built by ``multicosim images build --px4-dir DIR``, for ``backend="docker"``;
    with only a binary, the docker backend builds that image from the binary's bundle.
    ``model`` picks the airframe as ``PX4_SIM_MODEL`` does (``none_iris``: the generic quad
    our world simulates). ``params`` are set at boot (``param set`` in ``px4-rc.params``).
    ``start_timeout`` bounds (in wall seconds) PX4's start until it connects to its
    simulator; ``lockstep_timeout`` a lockstep step once it runs. ``first_instance`` is the
    lowest instance number a local run claims (the ones below stay free for PX4s started by
    hand on their usual ports).
    """

    binary: str | None = None
    image: str | None = None
    etc: str | None = None
    model: str = "none_iris"
    params: Mapping[str, float] = dataclasses.field(default_factory=dict)
    start_timeout: float = 60.0
    lockstep_timeout: float = 30.0
    first_instance: int = 0

    def __post_init__(self) -> None:
        if self.binary is None and self.image is None:
            raise ConfigurationError(
                "firmware", self, "px4.SITL(binary=PATH) or px4.SITL(image=NAME)"
            )
        if self.binary is not None:
            self._check_binary()
        if self.image is not None and (
            not isinstance(self.image, str) or not self.image.strip() or " " in self.image
        ):
            raise ConfigurationError("image", self.image, "a local image name such as 'name:tag'")
        if not isinstance(self.model, str) or not re.fullmatch(r"[A-Za-z0-9_]+", self.model):
            raise ConfigurationError("model", self.model, "an airframe name such as 'none_iris'")
        if self.binary is not None and not self.airframes():
            raise ConfigurationError(
                "model",
                self.model,
                f"an airframe of {self.etc_dir / 'init.d-posix' / 'airframes'} "
                "(a file named <id>_<model>)",
            )
        if not isinstance(self.params, Mapping):
            raise ConfigurationError("params", self.params, "a mapping of PX4 name to number")
        for name, value in self.params.items():
            if not isinstance(name, str) or not PARAM_NAME.match(name):
                raise ConfigurationError(
                    "params", name, "PX4 parameter names (upper case, at most 16 characters)"
                )
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not math.isfinite(value)
            ):
                raise ConfigurationError(f"params[{name!r}]", value, "a finite number")
        for field in ("start_timeout", "lockstep_timeout"):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
                raise ConfigurationError(field, value, "a positive number of seconds")
        check_first_instance(self.first_instance, MAX_INSTANCE)

    def _check_binary(self) -> None:
        binary = self.binary
        if not isinstance(binary, str | os.PathLike) or not str(binary):
            raise ConfigurationError("binary", binary, "the path of PX4's px4 executable")
        path = Path(binary)
        if not path.is_file():
            raise ConfigurationError("binary", binary, "an existing file (PX4's bin/px4)")
        if not os.access(path, os.X_OK):
            raise ConfigurationError("binary", binary, "an executable file (chmod +x)")
        rcs = self.etc_dir / "init.d-posix" / "rcS"
        if not rcs.is_file():
            raise ConfigurationError(
                "etc",
                str(self.etc_dir),
                "PX4's ROMFS directory with init.d-posix/rcS (etc= names it; by default the "
                "etc directory beside the binary's bin directory)",
            )

    @property
    def binary_path(self) -> Path:
        """The PX4 executable, resolved."""
        assert self.binary is not None
        return Path(self.binary).resolve()

    @property
    def bundle(self) -> Path:
        """The directory holding ``bin/px4`` and ``etc`` (what a PX4 image is built from)."""
        return _bundle_of(self.binary_path)

    @property
    def etc_dir(self) -> Path:
        """PX4's ROMFS directory."""
        if self.etc is not None:
            return Path(self.etc).resolve()
        return _bundle_of(Path(str(self.binary)).resolve()) / "etc"

    def airframes(self) -> list[Path]:
        """The airframe files of ``model`` in the ROMFS (one expected)."""
        folder = self.etc_dir / "init.d-posix" / "airframes"
        return sorted(p for p in folder.glob(f"*_{self.model}") if p.name.split("_")[0].isdigit())

    def modules(self) -> list[str]:
        """The ``px4-<module>`` commands beside the binary (links or flattened files)."""
        return sorted(
            p.name
            for p in self.binary_path.parent.glob("px4-*")
            if p.name != "px4-alias.sh" and "." not in p.name
        )


# -- instances ------------------------------------------------------------------------------


def _lock_held(instance: int) -> bool:
    # PX4 holds an flock on /tmp/px4_lock-N while instance N runs (a stale file is free).
    path = Path("/tmp") / f"px4_lock-{instance}"
    if not path.exists():
        return False
    try:
        with open(path, "rb") as f:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.flock(f, fcntl.LOCK_UN)
    except OSError as exc:
        return exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
    return False


def claim_instance(
    host: str = "127.0.0.1", *, gcs_link: bool = False, first: int = 0
) -> tuple[int, socket.socket]:
    """A free PX4 instance number from ``first`` on and its simulator port, bound and
    listening (the claim).

    Binding ``SIM_PORT + N`` is atomic, so two runs never claim the same instance; PX4's
    own UDP ports and lock file for ``N`` are checked free as well.
    """
    for n in range(first, MAX_INSTANCE + 1):
        if _lock_held(n):
            continue
        if not udp_free("127.0.0.1", API_LOCAL_PORT + n):
            continue
        if gcs_link and not udp_free("127.0.0.1", GCS_LOCAL_PORT + n):
            continue
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            sock.bind((host, SIM_PORT + n))
            sock.listen(4)
        except OSError:
            sock.close()
            continue
        return n, sock
    raise NodeStartError(
        "px4",
        f"no free PX4 instance: TCP ports {SIM_PORT}..{SIM_PORT + MAX_INSTANCE} "
        "(or PX4's UDP ports and lock files for them) are all in use",
    )


# -- the working directory ------------------------------------------------------------------


class MavlinkLink(NamedTuple):
    """One of PX4's MAVLink UDP links: bound on ``local_port``, sending to ``host:port``."""

    local_port: int
    host: str
    port: int
    mode: str = "onboard"

    def command(self) -> str:
        """The ``mavlink start`` line of PX4's start-up script for this link."""
        return (
            f"mavlink start -x -u {self.local_port} -r 4000000 -f -m {self.mode} "
            f"-o {self.port} -t {self.host}"
        )

    def text(self) -> str:
        """As one command-line word (``multicosim px4 launch --link``)."""
        return f"{self.local_port}:{self.host}:{self.port}:{self.mode}"

    @classmethod
    def parse(cls, text: str) -> MavlinkLink:
        """The link ``text()`` wrote."""
        local, host, port, mode = text.split(":")
        return cls(int(local), host, int(port), mode)


def gateway_links(host: str, instance: int) -> list[MavlinkLink]:
    """PX4's usual two links, sent to ``host`` (a container's way to the host's programs)."""
    return [
        MavlinkLink(GCS_LOCAL_PORT + instance, host, GCS_PORT, "normal"),
        MavlinkLink(API_LOCAL_PORT + instance, host, API_PORT + instance, "onboard"),
    ]


def prepare_rootfs(
    sitl: SITL,
    rootfs: Path,
    *,
    params: Mapping[str, float],
    links: Sequence[MavlinkLink] | None,
) -> dict[str, str]:
    """Make PX4's working directory ``rootfs``; return the environment to start PX4 with.

    ``links`` replace PX4's own MAVLink links (to our ground station, say); None keeps them
    (standalone SITL: QGroundControl and MAVSDK on their usual ports).
    """
    rootfs.mkdir(parents=True, exist_ok=True)
    bindir = rootfs / "bin"
    bindir.mkdir(exist_ok=True)
    binary = sitl.binary_path
    for name in sitl.modules():
        with contextlib.suppress(FileExistsError):
            (bindir / name).symlink_to(binary)
    alias = binary.parent / "px4-alias.sh"
    if alias.is_file():
        with contextlib.suppress(FileExistsError):
            (bindir / "px4-alias.sh").symlink_to(alias)
    lines = ["#!/bin/sh", "# multicosim: parameters for this run"]
    lines += [f"param set {name} {param_value(value)}" for name, value in params.items()]
    (bindir / "px4-rc.params").write_text("\n".join(lines) + "\n")
    if links is not None:
        script = ["#!/bin/sh", "# multicosim: PX4's MAVLink links for this run"]
        script += [link.command() for link in links]
        (bindir / "px4-rc.mavlink").write_text("\n".join(script) + "\n")
    return {
        "PX4_SIM_MODEL": sitl.model,
        "PATH": f"{bindir}:{os.environ.get('PATH', '/usr/bin:/bin')}",
    }


def launch_command(sitl: SITL, rootfs: Path, instance: int) -> list[str]:
    """The command that starts PX4 (daemon mode, instance ``instance``, in ``rootfs``)."""
    return [str(sitl.binary_path), "-d", "-i", str(instance), "-w", str(rootfs), str(sitl.etc_dir)]


def exec_in_container(
    *,
    instance: int,
    sim_host: str,
    links: Sequence[MavlinkLink] | None,
    params: Mapping[str, float],
    model: str,
) -> None:
    """Prepare PX4's working directory in its container and become PX4 (never returns).

    The entry point of the PX4 image (``multicosim px4 launch``).
    """
    sitl = SITL(binary=f"{CONTAINER_BUNDLE}/bin/px4", model=model)
    rootfs = Path(CONTAINER_ROOTFS)
    env = prepare_rootfs(sitl, rootfs, params=params, links=links)
    env["PX4_SIM_HOST_ADDR"] = sim_host
    args = launch_command(sitl, rootfs, instance)
    os.chdir(rootfs)
    os.execve(args[0], args, {**os.environ, **env})


def container_command(
    *,
    instance: int,
    sim_host: str,
    links: Sequence[MavlinkLink],
    params: Mapping[str, float],
    model: str,
) -> list[str]:
    """The PX4 image's command for ``exec_in_container``'s arguments."""
    command = ["multicosim", "px4", "launch", "--instance", str(instance), "--sim-host", sim_host]
    for link in links:
        command += ["--link", link.text()]
    return [*command, "--model", model, "--params", json.dumps(dict(params))]


# -- starting it ----------------------------------------------------------------------------


class PX4Launch:
    """Real PX4 for the firmware launcher (``multicosim.placement.firmware.launch``).

    Claims an instance (its simulator port bound, its UDP ports and lock file checked free)
    where PX4 shares this machine's ports, or instance 0 on a network of its own; starts the
    simulator bridge (and, with an ``uplink``, the bridge of its MAVLink link to our ground
    station) in this process; runs PX4 in a fresh working directory (or its image's).
    """

    waiting_for = "connect to its simulator"

    def __init__(
        self,
        sitl: SITL,
        *,
        name: str,
        topics: Topics,
        home_alt: float,
        period: float,
        wire: Wire,
        uplink: str | None,
        downlink: str,
        params: Mapping[str, float],
    ) -> None:
        self.sitl = sitl
        self._home_alt = home_alt
        self.name = name
        self.start_timeout = sitl.start_timeout
        self._topics = topics
        self._period = period
        self._wire = wire
        self._uplink = uplink
        self._downlink = downlink
        self._params = params
        self._server: socket.socket | None = None
        self.instance = 0
        self.bridge: HilTcpBridge | None = None
        self.link: UdpBridge | None = None

    def claim(self, endpoint: Endpoint) -> int:
        """Instance 0 on a private network; else the first free instance from the SITL's."""
        if endpoint.private:
            self.instance, self._server = 0, _listen(endpoint.host, SIM_PORT)
        else:
            self.instance, self._server = claim_instance(
                endpoint.host, gcs_link=self._uplink is None, first=self.sitl.first_instance
            )
        return self.instance

    def bridges(self, endpoint: Endpoint) -> list[tuple[str, Component[Any, Node]]]:
        """The simulator bridge, and the bridge of PX4's API link to our ground station."""
        from ..local import InProcessComponent

        server = self._server
        assert server is not None

        def simulator_bridge() -> HilTcpBridge:
            self.bridge = HilTcpBridge(
                self._topics,
                home_alt=self._home_alt,
                period=self._period,
                server=server,
                lockstep_timeout=self.sitl.lockstep_timeout,
                wire=self._wire,
                name=self.name,
            )
            return self.bridge

        found: list[tuple[str, Component[Any, Node]]] = [
            (f"{self.name}.hil", InProcessComponent(simulator_bridge, f"{self.name}.hil"))
        ]
        uplink = self._uplink
        if uplink is not None:
            # The bridge carries a ground station's UDP traffic to an autopilot's topics; here
            # PX4 is on the UDP side, so what it sends goes down to our ground station.
            local = Link(API_LOCAL_PORT + self.instance, 0, endpoint.host)

            def api_link() -> UdpBridge:
                self.link = UdpBridge([local], self._downlink, uplink, 0.01)
                return self.link

            found.append((f"{self.name}.link", InProcessComponent(api_link, f"{self.name}.link")))
        return found

    def _links(self, endpoint: Endpoint) -> list[MavlinkLink] | None:
        if self.link is not None:
            port = self.link.local_ports[0]
            return [MavlinkLink(API_LOCAL_PORT + self.instance, endpoint.host, port)]
        # On a network of its own, PX4 sends its usual links to the host's ports.
        return gateway_links(endpoint.host, self.instance) if endpoint.private else None

    def program(self, endpoint: Endpoint, workdir: Path) -> ProgramSpec:
        """PX4 in ``workdir`` (a binary), or the PX4 image (built from the binary's bundle
        when only a binary is given)."""
        sitl, links = self.sitl, self._links(endpoint)
        command = env = None
        if sitl.binary is not None:
            env = prepare_rootfs(sitl, workdir, params=self._params, links=links)
            command = launch_command(sitl, workdir, self.instance)
        image_command = container_command(
            instance=self.instance,
            sim_host=endpoint.host,
            links=links or [],
            params=self._params,
            model=sitl.model,
        )
        return ProgramSpec(
            name=self.name,
            command=command,
            env=env or {},
            cwd=str(workdir),
            image=image_of(sitl),
            image_command=image_command,
            image_workdir=CONTAINER_ROOTFS,
        )

    def started(self, program: ProgramNode, endpoint: Endpoint) -> None:
        """Watch PX4 from the simulator bridge (its exit fails the step that waits on it)."""
        assert self.bridge is not None
        self.bridge.watch = program

    def ready(self) -> bool:
        """Whether PX4 has connected to its simulator bridge."""
        return self.bridge is not None and self.bridge.poll_connection()

    def release(self) -> None:
        """Close the claimed simulator port unless the bridge took it."""
        if self.bridge is None and self._server is not None:
            self._server.close()


def image_of(sitl: SITL) -> str | Callable[[], str] | None:
    """The PX4 image a container runs: the SITL's, or one built from its binary's bundle
    (on first use; a build whose inputs did not change is skipped)."""
    if sitl.image is not None or sitl.binary is None:
        return sitl.image
    bundle = sitl.bundle

    def build() -> str:
        from .image import build_image

        return build_image(bundle)

    return build


def start_sitl(
    sitl: SITL,
    placement: Placement,
    environment: LocalEnvironment,
    *,
    name: str,
    topics: Topics,
    home_alt: float,
    period: float,
    wire: Wire,
    uplink: str | None,
    downlink: str,
    params: Mapping[str, float],
) -> FirmwareNodes:
    """Start PX4 where ``placement`` runs programs, with its bridges in this process.

    With an ``uplink``, PX4's one MAVLink link is carried on ``uplink``/``downlink`` (for
    the simulation's ground station); without, PX4 keeps its own links on its usual ports
    (standalone SITL). ``home_alt`` is the world's home altitude (m AMSL), for the ground
    truth PX4 is sent. Returns once PX4 has connected to its simulator bridge; PX4 then
    waits, in lockstep, for the simulation's clock.
    """
    px4 = PX4Launch(
        sitl,
        name=name,
        topics=topics,
        home_alt=home_alt,
        period=period,
        wire=wire,
        uplink=uplink,
        downlink=downlink,
        params=params,
    )
    return launch(px4, placement, environment)


def _listen(host: str, port: int) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(4)
    except OSError as exc:
        sock.close()
        raise NodeStartError("px4", f"could not listen on {host}:{port} for PX4: {exc}") from exc
    return sock
