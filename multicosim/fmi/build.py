"""An FMU's binary and image: compiled from its C sources with FMPy where it has no binary
for this platform, and copied onto the runtime image for a container."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ..core.errors import ConfigurationError, NodeStartError
from ..core.version import __version__
from .model import Model, describe

__all__ = ["IN_IMAGE", "build_image", "image_entry", "no_binary", "prepare"]

# Where a container finds its FMU (images/fmu/Dockerfile copies it there).
IN_IMAGE = "/opt/fmu"
_COMPILE_TIMEOUT = 300.0


def no_binary(model: Model) -> str:
    """Why ``model`` cannot run here, and what could be done: an error's 'allowed' text."""
    from fmpy import platform

    others = [p for p in model.platforms if p != "c-code"] or ["none"]
    text = f"an FMU with a binary for this platform ({platform}); {model.label} has binaries for: "
    text += ", ".join(others)
    if model.has_sources:
        return (
            f"{text}; it carries C sources: compile=True builds a binary with FMPy "
            "(needs cmake and a C compiler)"
        )
    return text + ", and no C sources to build one from"


def prepare(model: Model, directory: Path) -> Path:
    """The FMU extracted into ``directory`` with a binary compiled from its sources by FMPy.

    NodeStartError (with the compiler's output) if the build fails or takes longer than
    five minutes.
    """
    from fmpy import extract

    directory.mkdir(parents=True, exist_ok=True)
    unzipped = directory / "fmu"
    if model.path.is_dir():
        shutil.copytree(model.path, unzipped, dirs_exist_ok=True)
    else:
        extract(str(model.path), str(unzipped))
    build = directory / "build"
    build.mkdir(exist_ok=True)
    script = (
        "import json, sys, fmpy.build; fmpy.build.build_platform_binary("
        "sys.argv[1], build_dir=sys.argv[2], cmake_options=json.loads(sys.argv[3]))"
    )
    options = {}
    if model.fmi_version.startswith("3"):
        # FMPy 0.3.32 defines an empty function prefix on Windows only: elsewhere the FMI 3
        # functions of a source FMU keep the model identifier's prefix, and FMPy finds none.
        options["CMAKE_C_FLAGS:STRING"] = "-DFMI3_FUNCTION_PREFIX="
    # FMPy runs cmake, which its PyPI dependency puts beside this interpreter.
    env = {
        **os.environ,
        "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]),
    }
    try:
        done = subprocess.run(
            [sys.executable, "-c", script, str(unzipped), str(build), json.dumps(options)],
            capture_output=True,
            text=True,
            timeout=_COMPILE_TIMEOUT,
            env=env,
            check=False,
        )
    except subprocess.TimeoutExpired as exc:
        raise NodeStartError(
            model.name, f"could not be compiled within {_COMPILE_TIMEOUT:g} s"
        ) from exc
    finally:
        shutil.rmtree(build, ignore_errors=True)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).splitlines()[-30:])
        raise NodeStartError(
            model.name, "could not be compiled from its C sources with FMPy", log_tail=tail
        )
    return unzipped


def image_entry(model: Model) -> str:
    """The FMU's name in its image's /opt/fmu (a directory when it is compiled)."""
    return "model" if model.path.is_dir() or not model.runnable_here else model.path.name


def build_image(path: str | os.PathLike[str], *, compile: bool = False, force: bool = False) -> str:
    """Build the image of the FMU at ``path`` (the runtime image with FMPy, the FMU copied
    to /opt/fmu); return its tag. Built locally like every multicosim image (never pulled);
    skipped when it exists for the same FMU. ``compile`` builds its binary from its C sources
    first (on this machine, with FMPy), where it has none for this platform."""
    from ..docker import build_derived

    model = describe(path)
    if not model.runnable_here and not compile:
        raise ConfigurationError("path", str(path), no_binary(model))
    digest = _content_digest(model.path)
    slug = re.sub(r"[^a-z0-9_.-]", "-", model.path.stem.lower()).strip("-.") or "fmu"
    tag = f"multicosim/fmu-{slug}:{__version__}-{digest[:12]}"
    entry = image_entry(model)
    if model.runnable_here:
        return build_derived("fmu", {f"fmu/{entry}": model.path}, tag=tag, force=force)
    with tempfile.TemporaryDirectory(prefix="mcs-fmu-compile-") as tmp:
        compiled = prepare(model, Path(tmp))
        return build_derived("fmu", {f"fmu/{entry}": compiled}, tag=tag, force=force)


def _content_digest(path: Path) -> str:
    h = hashlib.sha256()
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    for file in files:
        h.update(str(file.relative_to(path) if path.is_dir() else file.name).encode() + b"\0")
        h.update(file.read_bytes())
    return h.hexdigest()
