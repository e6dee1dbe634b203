"""Where AeroBench is: a directory its user names, checked, and its models loaded from there.

AeroBench (AeroBenchVVPython, GPL-3.0, not on PyPI) is not part of multicosim: it is loaded
at run time from the directory the user names, in the process that flies the F-16 (the
simulation's own, a local process, or a container it is mounted into, read-only).
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

from ..core.deps import require
from ..core.errors import ConfigurationError

__all__ = ["AEROBENCH_ENV", "AeroBench", "Models", "load"]

AEROBENCH_ENV = "MCS_AEROBENCH_DIR"
"""The environment variable naming AeroBench's directory where none is given."""

# What the F-16 participant imports, relative to the directory that holds ``aerobench/``:
# a directory without them is not AeroBench (or not the version the participant knows).
REQUIRED = (
    "aerobench/run_f16_sim.py",
    "aerobench/util.py",
    "aerobench/highlevel/autopilot.py",
    "aerobench/highlevel/controlled_f16.py",
    "aerobench/lowlevel/low_level_controller.py",
    "aerobench/lowlevel/subf16_model.py",
    "aerobench/lowlevel/morellif16.py",
    "aerobench/examples/gcas/gcas_autopilot.py",
)

_WHAT = (
    "AeroBench's directory (AeroBenchVVPython: code/aerobench/run_f16_sim.py, ... and the "
    "GCAS example), or its code/ directory"
)


def _missing(code: Path) -> list[str]:
    return [name for name in REQUIRED if not (code / name).is_file()]


@dataclasses.dataclass(frozen=True)
class AeroBench:
    """AeroBench's F-16 models, in the directory ``directory`` names, checked now.

    ``directory`` is AeroBench's checkout (with ``code/aerobench/``) or its ``code/``
    directory; None reads the ``MCS_AEROBENCH_DIR`` environment variable. Nothing is copied:
    the component imports the models from there when it runs.

    Raises:
        ConfigurationError: naming ``directory`` (or ``MCS_AEROBENCH_DIR``) when none is
            given, the directory does not exist, or it does not hold AeroBench's models.
    """

    directory: str | os.PathLike[str] | None = None
    root: Path = dataclasses.field(init=False)
    """The directory as given, resolved."""
    code: Path = dataclasses.field(init=False)
    """The directory that holds the ``aerobench`` package (what goes on ``sys.path``)."""

    def __post_init__(self) -> None:
        field = "directory"
        given: object = self.directory
        if given is None:
            field, given = AEROBENCH_ENV, os.environ.get(AEROBENCH_ENV) or None
        if given is None:
            raise ConfigurationError(
                "directory", None, f"{_WHAT}: pass directory=... or set {AEROBENCH_ENV}"
            )
        if not isinstance(given, str | os.PathLike) or not str(given).strip():
            raise ConfigurationError(field, given, f"a path: {_WHAT}")
        root = Path(given).expanduser().resolve()
        if not root.is_dir():
            raise ConfigurationError(field, str(given), f"an existing directory: {_WHAT}")
        code = root / "code" if (root / "code" / "aerobench").is_dir() else root
        missing = _missing(code)
        if missing:
            raise ConfigurationError(field, str(given), f"{_WHAT} (missing: {', '.join(missing)})")
        object.__setattr__(self, "root", root)
        object.__setattr__(self, "code", code)

    def __str__(self) -> str:
        return str(self.root)


@dataclasses.dataclass(frozen=True)
class Models:
    """What the F-16 participant uses of AeroBench, loaded in this process.

    ``make_der_func`` is the closed-loop derivative (the F-16, its low-level controller and
    the autopilot), ``gcas`` the GCAS autopilot class, ``euler`` AeroBench's fixed-step
    integrator; ``source`` is the directory they were loaded from.
    """

    make_der_func: Any
    gcas: Any
    euler: Any
    source: Path


def _origin(module: ModuleType) -> Path | None:
    file = getattr(module, "__file__", None)
    return Path(file).resolve() if file else None


def load(code: str | os.PathLike[str]) -> Models:
    """AeroBench's models from ``code`` (the directory holding ``aerobench/``), imported
    into this process, which flies the F-16.

    One process holds one AeroBench: a second directory is refused rather than silently
    mixed with the first.

    Raises:
        ConfigurationError: naming ``directory`` where ``code`` is not AeroBench's, or this
            process already loaded AeroBench from elsewhere.
        DependencyMissingError: without scipy (``pip install 'multicosim[f16]'``).
    """
    where = Path(code).resolve()
    missing = _missing(where)
    if missing:
        raise ConfigurationError("directory", str(code), f"{_WHAT} (missing: {missing[0]})")
    loaded = sys.modules.get("aerobench.run_f16_sim")
    if loaded is None and str(where) not in sys.path:
        # AeroBench is imported as its example scripts import it: from its code/ directory.
        sys.path.insert(0, str(where))
    # AeroBench integrates with scipy: missing, it is the f16 extra that says so, not AeroBench.
    require("scipy.integrate", "f16")
    run = importlib.import_module("aerobench.run_f16_sim")
    origin = _origin(run)
    if origin is None or not origin.is_relative_to(where):
        raise ConfigurationError(
            "directory",
            str(code),
            f"the AeroBench this process loaded first ({origin}): one process flies one "
            "AeroBench (use placement='process' to fly others)",
        )
    gcas = importlib.import_module("aerobench.examples.gcas.gcas_autopilot")
    util = importlib.import_module("aerobench.util")
    return Models(run.make_der_func, gcas.GcasAutopilot, util.Euler, where)
