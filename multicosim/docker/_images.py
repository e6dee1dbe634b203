"""Build multicosim's images locally; never pull.

``build()`` builds the runtime image (``multicosim/runtime:VERSION``) from ``images/runtime``
with the classic builder. Its base is ``python:3.11-slim`` when that image is present
locally; otherwise a Debian bookworm base is made from Debian's archive with debootstrap and
``docker import`` (no container registry is needed at any point). A build whose inputs did
not change is skipped, so calling it again is fast.
"""

from __future__ import annotations

import fcntl
import hashlib
import logging
import os
import re
import shutil
import subprocess
import tempfile
import tomllib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from ..core.errors import MulticosimError
from ..core.version import __version__

__all__ = [
    "BASE_IMAGE",
    "RUNTIME_IMAGE",
    "build",
    "build_base",
    "build_derived",
    "build_from_directory",
    "build_runtime",
    "debian_mirror",
]

log = logging.getLogger(__name__)

RUNTIME_IMAGE = f"multicosim/runtime:{__version__}"
"""The image every multicosim component program runs from."""

BASE_IMAGE = "multicosim/base:bookworm"
"""The base image made from Debian's archive when no Python base image is present."""

UPSTREAM_BASE = "python:3.11-slim"
"""The Dockerfiles' default base, used when present locally."""

# The runtime image carries these extras of the package (pinned in pyproject.toml).
RUNTIME_EXTRAS = ("mujoco", "mavlink", "fmi", "f16")

LABEL_INPUTS = "multicosim.inputs"
_BUILD_LOCK = Path(tempfile.gettempdir()) / f"multicosim-{os.getuid()}-build.lock"
_CA_BUNDLES = ("/etc/ssl/certs/ca-certificates.crt", "/etc/pki/tls/certs/ca-bundle.crt")
_SOURCES = ("pyproject.toml", "README.md", "multicosim", "pytest_multicosim")


def _repo_root() -> Path:
    root = Path(__file__).resolve().parents[2]
    if not (root / "images" / "runtime" / "Dockerfile").is_file():
        raise MulticosimError(
            f"cannot build images: {root} is not a multicosim source tree (images/ is missing)"
        )
    return root


def debian_mirror(sources: Path = Path("/etc/apt/sources.list.d/debian.sources")) -> str:
    """The Debian archive this machine's apt uses (read now, never hard-coded)."""
    override = os.environ.get("MCS_DEBIAN_MIRROR")
    if override:
        return override
    if sources.is_file():
        for stanza in sources.read_text().split("\n\n"):
            fields = dict(
                line.split(":", 1) for line in stanza.splitlines() if re.match(r"^\w[\w-]*:", line)
            )
            suites = fields.get("Suites", "").split()
            if "bookworm" in suites and "URIs" in fields:
                return fields["URIs"].split()[0]
    legacy = Path("/etc/apt/sources.list")
    if legacy.is_file():
        for line in legacy.read_text().splitlines():
            parts = line.split()
            if len(parts) >= 3 and parts[0] == "deb" and parts[2] == "bookworm":
                return parts[1] if not parts[1].startswith("[") else parts[2]
    raise MulticosimError(
        "cannot find a Debian bookworm mirror in apt's sources; set MCS_DEBIAN_MIRROR"
    )


def _image_exists(api: Any, name: str) -> bool:
    from .engine import ImageNotFound

    try:
        api.inspect_image(name)
    except ImageNotFound:
        return False
    return True


def build_base(tag: str = BASE_IMAGE, *, mirror: str | None = None) -> str:
    """Make a Debian bookworm base image with Python 3.11 from Debian's archive; return it.

    Needs root and ``debootstrap`` (``apt-get install -y debootstrap``); takes about a minute.
    """
    if shutil.which("debootstrap") is None:
        raise MulticosimError(
            "building the base image needs debootstrap: apt-get install -y debootstrap "
            "(or make python:3.11-slim available locally)"
        )
    if os.geteuid() != 0:
        raise MulticosimError("debootstrap needs root to build the base image")
    mirror = mirror or debian_mirror()
    from .engine import client

    api = client().api
    rootfs = Path(tempfile.mkdtemp(prefix="mcs-rootfs-"))
    try:
        log.info("debootstrap bookworm from %s (about a minute)", mirror)
        # debootstrap does not resolve virtual packages: list what pyzmq & co. need.
        _run(
            [
                "debootstrap",
                "--variant=minbase",
                "--include=python3,python3-venv,python3-cffi-backend",
                "bookworm",
                str(rootfs),
                mirror,
            ]
        )
        for cache in ("var/cache/apt/archives", "var/lib/apt/lists"):
            for item in (rootfs / cache).glob("*"):
                if item.is_file():
                    item.unlink()
        repository, _, version = tag.rpartition(":")
        with subprocess.Popen(
            ["tar", "-C", str(rootfs), "--numeric-owner", "-c", "."], stdout=subprocess.PIPE
        ) as tar:
            assert tar.stdout is not None
            api.import_image_from_stream(
                tar.stdout,
                repository=repository,
                tag=version,
                changes=["ENV LANG=C.UTF-8", 'CMD ["python3"]'],
            )
        if tar.returncode != 0:
            raise MulticosimError(f"tar of the base root file system failed ({tar.returncode})")
    finally:
        shutil.rmtree(rootfs, ignore_errors=True)
    return tag


def _run(args: list[str]) -> None:
    result = subprocess.run(args, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        tail = "\n".join((result.stdout + result.stderr).splitlines()[-30:])
        raise MulticosimError(f"{args[0]} failed ({result.returncode}):\n{tail}")


def _requirements(pyproject: dict[str, Any], extras: Iterable[str]) -> list[str]:
    project = pyproject["project"]
    optional: dict[str, list[str]] = project.get("optional-dependencies", {})
    reqs: list[str] = list(project.get("dependencies", []))
    pending, seen = list(extras), set()
    while pending:
        extra = pending.pop()
        if extra in seen:
            continue
        seen.add(extra)
        for req in optional[extra]:
            self_ref = re.fullmatch(r"multicosim\[([\w,\s-]+)\]", req.strip())
            if self_ref:
                pending.extend(e.strip() for e in self_ref.group(1).split(","))
            else:
                reqs.append(req)
    return sorted(set(reqs))


def _host_ca_bundle() -> Path:
    for candidate in (os.environ.get("SSL_CERT_FILE"), *_CA_BUNDLES):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    raise MulticosimError("no CA bundle found on this host (needed by pip inside the build)")


def _prepare_context(context: Path) -> None:
    root = _repo_root()
    shutil.copy(root / "images" / "runtime" / "Dockerfile", context / "Dockerfile")
    shutil.copy(_host_ca_bundle(), context / "host-ca.crt")
    pyproject = tomllib.loads((root / "pyproject.toml").read_text())
    (context / "requirements.txt").write_text(
        "\n".join(_requirements(pyproject, RUNTIME_EXTRAS)) + "\n"
    )
    src = context / "src"
    src.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", ".*cache")
    for name in _SOURCES:
        path = root / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=ignore)
        elif path.is_file():
            shutil.copy(path, src / name)
    if not (src / "README.md").exists():
        # pyproject.toml names a readme; the build backend refuses to build without one.
        (src / "README.md").write_text("multicosim\n")


def _digest(context: Path, base_id: str) -> str:
    h = hashlib.sha256(base_id.encode())
    for path in sorted(p for p in context.rglob("*") if p.is_file()):
        h.update(str(path.relative_to(context)).encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:24]


def build_runtime(
    *,
    base: str,
    tag: str = RUNTIME_IMAGE,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> str:
    """Build the runtime image on ``base`` (which must exist locally); return its tag.

    Skipped when an image ``tag`` built from the same inputs exists, unless ``force``.
    """
    with tempfile.TemporaryDirectory(prefix="mcs-build-") as tmp:
        context = Path(tmp)
        _prepare_context(context)
        return _build_context(context, base=base, tag=tag, force=force, progress=progress)


def _build_context(
    context: Path,
    *,
    base: str,
    tag: str,
    force: bool,
    progress: Callable[[str], None] | None,
) -> str:
    """Build ``context`` on ``base`` as ``tag`` unless an image of the same inputs exists."""
    from .engine import client

    api = client().api
    if not _image_exists(api, base):
        raise MulticosimError(f"base image {base!r} is not present locally (never pulled)")
    base_id: str = api.inspect_image(base)["Id"]
    digest = _digest(context, base_id)
    if not force and _image_exists(api, tag):
        current = (api.inspect_image(tag)["Config"].get("Labels") or {}).get(LABEL_INPUTS)
        if current == digest:
            log.info("%s is up to date", tag)
            return tag
    log.info("building %s on %s", tag, base)
    lines: list[str] = []
    for chunk in api.build(
        path=str(context),
        tag=tag,
        buildargs={"BASE": base},
        labels={LABEL_INPUTS: digest},
        pull=False,
        rm=True,
        forcerm=True,
        decode=True,
    ):
        if "error" in chunk:
            tail = "".join(lines[-30:])
            raise MulticosimError(f"building {tag} failed: {chunk['error']}\n{tail}")
        text = chunk.get("stream")
        if text:
            lines.append(text)
            if progress is not None:
                progress(text.rstrip("\n"))
    return tag


def build_from_directory(
    name: str,
    directory: str | os.PathLike[str],
    *,
    required: tuple[str, ...],
    parts: tuple[str, ...],
    what: str,
    tag: str,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> str:
    """Build ``images/<name>`` on the runtime image with ``parts`` of ``directory``.

    For a firmware build (a SITL directory): ``required`` files must be in it (else the
    error says it is not ``what``); its licence file goes in too. The vehicle packages
    build their images with it (``multicosim.px4.image``, ``multicosim.ardupilot.image``).
    """
    root = Path(directory)
    missing = [p for p in required if not (root / p).is_file()]
    if missing:
        raise MulticosimError(f"{root} is not {what}: {', '.join(missing)} missing")
    files = {f"{name}/{part}": root / part for part in parts}
    for extra in ("LICENSE", "COPYING.txt"):
        if (root / extra).is_file():
            files[f"{name}/{extra}"] = root / extra
    return build_derived(name, files, tag=tag, force=force, progress=progress)


def build_derived(
    name: str,
    files: Mapping[str, Path],
    *,
    tag: str,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> str:
    """Build ``images/<name>/Dockerfile`` on the runtime image; return ``tag``.

    ``files`` maps paths in the build context to files or directories of this machine (the
    Dockerfile says where they go in the image). The runtime image is built first if its
    source changed; like every build here, nothing is pulled, and an image whose inputs did
    not change is not built again (unless ``force``). Used by the real-firmware images and
    by ``multicosim.fmi`` (an FMU in the runtime image).
    """
    runtime = build(force=False, progress=progress)[0]
    with open(_BUILD_LOCK, "w") as lock, tempfile.TemporaryDirectory(prefix=f"mcs-{name}-") as tmp:
        fcntl.flock(lock, fcntl.LOCK_EX)
        context = Path(tmp)
        shutil.copy(_repo_root() / "images" / name / "Dockerfile", context / "Dockerfile")
        for target, source in files.items():
            destination = context / target
            destination.parent.mkdir(parents=True, exist_ok=True)
            if source.is_dir():
                shutil.copytree(source, destination, symlinks=True)
            else:
                shutil.copy(source, destination)
        return _build_context(context, base=runtime, tag=tag, force=force, progress=progress)


def build(
    *,
    base: str | None = None,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[str]:
    """Build multicosim's runtime image locally (and its base if missing); return its tag.

    ``base``: the base image to build on (default: python:3.11-slim if present locally, else
    multicosim's Debian base, made with debootstrap if missing). A vehicle's firmware image
    is built by its package (``multicosim images build --px4-dir DIR``).
    """
    from .engine import client

    api = client().api
    # Parallel test workers (xdist) all ask for the images: build them once, in turn.
    with open(_BUILD_LOCK, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return _build_locked(api, base, force, progress)


def _build_locked(
    api: Any, base: str | None, force: bool, progress: Callable[[str], None] | None
) -> list[str]:
    if base is None:
        if _image_exists(api, UPSTREAM_BASE):
            base = UPSTREAM_BASE
        else:
            base = BASE_IMAGE
            if force or not _image_exists(api, BASE_IMAGE):
                if progress is not None:
                    progress(f"making {BASE_IMAGE} from Debian's archive with debootstrap")
                build_base(BASE_IMAGE)
    return [build_runtime(base=base, force=force, progress=progress)]
