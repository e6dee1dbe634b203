"""The ``--mcs-*`` options, their ini twins, and the validated
[`Settings`][pytest_multicosim.options.Settings] of a run.

Every option lives in the ``multicosim`` group and has an ini twin of the same name
(``mcs_fidelity = low,medium`` in ``pytest.ini``); the command line wins over the ini file.
A bad value raises ``pytest.UsageError`` naming where it came from and what is allowed.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import os
import shlex
import tempfile
from pathlib import Path

import pytest

from multicosim.core.fidelity import FIDELITIES, check_fidelity
from multicosim.placement.registry import ENTRY_POINTS, default_placement, placement_names

__all__ = [
    "FIRMWARE_DESTS",
    "KEEP_TRACES",
    "OPTION_DESTS",
    "Settings",
    "add_options",
    "given",
    "parse_fidelity",
    "read_settings",
    "settings_key",
    "sourced",
]

KEEP_TRACES = ("failed", "all", "none")
_ARTIFACTS_DEFAULT = "mcs-artifacts"

# Every option of the group that makes the plugin act for every test of the session when
# given on the command line (or in addopts).
OPTION_DESTS = (
    "mcs_fidelity",
    "mcs_placement",
    "mcs_seed",
    "mcs_artifacts",
    "mcs_keep_traces",
    "mcs_px4_image",
    "mcs_px4_binary",
    "mcs_ray",
    "mcs_repeat",
    "mcs_repeat_load",
)

FIRMWARE_DESTS = ("mcs_px4_image", "mcs_px4_binary", "mcs_ardupilot_dir", "mcs_aerobench_dir")
"""The options naming firmware and models from outside the package, each with an environment
twin (``MCS_PX4_BINARY``, ...)."""


def sourced(config: pytest.Config, dest: str) -> str | None:
    """The option ``dest``, else its ini twin, else its environment variable (``mcs_px4_binary``:
    ``MCS_PX4_BINARY``); None when none is set."""
    value = config.getoption(dest) or config.getini(dest)
    return str(value) if value else os.environ.get(dest.upper()) or None


@dataclasses.dataclass(frozen=True)
class Settings:
    """The validated multicosim options of a pytest run."""

    fidelity: tuple[str, ...]
    placement: str | None
    """The placement named (None: each fidelity's default)."""
    seed: int
    artifacts: Path
    keep_traces: str
    ray: str | None = None
    repeat: int = 1
    """How many times each simulation test runs (``--mcs-repeat``)."""
    repeat_load: int = 0
    """Busy processes the plugin starts while tests repeat (``--mcs-repeat-load``)."""
    competition: tuple[Path, ...] = ()
    """Folders whose UAV test competition cases are collected (``--mcs-competition``)."""

    def replay_args(self, fidelity: str | None) -> str:
        """Command-line options that replay a test with the same seed, fidelity and placement,
        writing where this run wrote (its artifacts directory, absolute)."""
        level = fidelity or ",".join(self.fidelity)
        placement = f" --mcs-placement={self.placement}" if self.placement else ""
        ray = f" --mcs-ray={shlex.quote(self.ray)}" if self.ray else ""
        traces = f" --mcs-keep-traces={self.keep_traces}" if self.keep_traces != "failed" else ""
        if self.repeat > 1:
            traces += f" --mcs-repeat={self.repeat}"
        if self.repeat_load:
            traces += f" --mcs-repeat-load={self.repeat_load}"
        artifacts = shlex.quote(str(self.artifacts.absolute()))
        return (
            f"--mcs-seed={self.seed} --mcs-fidelity={level}{placement}{ray}"
            f" --mcs-artifacts={artifacts}{traces}"
        )

    def placement_for(self, fidelity: str | None) -> str:
        """The name of the placement a test at ``fidelity`` runs in (None: the first level
        selected, as the ``mcs_fidelity`` fixture gives a test not parametrized by level)."""
        if self.placement is not None:
            return self.placement
        return default_placement(check_fidelity(fidelity or self.fidelity[0]))


settings_key = pytest.StashKey[Settings]()
"""Where ``config.stash`` keeps the run's [`Settings`][pytest_multicosim.options.Settings]."""


def add_options(parser: pytest.Parser) -> None:
    """Add the ``multicosim`` option group and the options' ini twins to ``parser``."""
    group = parser.getgroup("multicosim", "multicosim co-simulation")
    group.addoption(
        "--mcs-fidelity",
        dest="mcs_fidelity",
        default=None,
        help="fidelity level(s) to run: low, medium, high, or a comma list (default: low)",
    )
    group.addoption(
        "--mcs-placement",
        dest="mcs_placement",
        default=None,
        help="where components run: in-process, process, docker, or another registered "
        "placement (default: in-process at low fidelity, process above)",
    )
    group.addoption(
        "--mcs-seed",
        dest="mcs_seed",
        default=None,
        help="seed for every random source of the simulations (default: 0)",
    )
    group.addoption(
        "--mcs-artifacts",
        dest="mcs_artifacts",
        default=None,
        help="directory for traces and logs of failing tests (default: mcs-artifacts)",
    )
    group.addoption(
        "--mcs-keep-traces",
        dest="mcs_keep_traces",
        default=None,
        help="which tests keep their traces: failed (default), all or none",
    )
    group.addoption(
        "--mcs-px4-image",
        dest="mcs_px4_image",
        default=None,
        help="fly real PX4 too: a PX4 SITL image (multicosim images build --px4-dir DIR; "
        "env MCS_PX4_IMAGE)",
    )
    group.addoption(
        "--mcs-px4-binary",
        dest="mcs_px4_binary",
        default=None,
        help="fly real PX4 too: its SITL binary (bin/px4 with etc/ beside bin/, e.g. "
        "build/px4_sitl_default/bin/px4; env MCS_PX4_BINARY)",
    )
    group.addoption(
        "--mcs-ardupilot-dir",
        dest="mcs_ardupilot_dir",
        default=None,
        help="fly real ArduPilot on the ArduPilot fixtures: its SITL directory (bin/arducopter, "
        "bin/ardurover, params/; env MCS_ARDUPILOT_DIR)",
    )
    group.addoption(
        "--mcs-aerobench-dir",
        dest="mcs_aerobench_dir",
        default=None,
        help="fly the F-16 fixtures on AeroBench from this directory (AeroBenchVVPython, with "
        "code/aerobench/; env MCS_AEROBENCH_DIR; default: ../shared/aerobench beside the "
        "project)",
    )
    group.addoption(
        "--mcs-ray",
        dest="mcs_ray",
        default=None,
        help="run campaigns (mcs_campaign_executor) on the Ray cluster at ADDRESS "
        "(auto, local, ray://head:10001, ...; default: the local process pool)",
    )
    group.addoption(
        "--mcs-repeat",
        dest="mcs_repeat",
        default=None,
        help="run every simulation test K times with the same seed and fail it if its "
        "verdict or any sample changes (naming the first that does; default: 1)",
    )
    group.addoption(
        "--mcs-repeat-load",
        dest="mcs_repeat_load",
        nargs="?",
        const=str(2 * (os.cpu_count() or 1)),
        default=None,
        help="while tests repeat, keep N busy processes running (alone: twice as many as "
        "cores; default: 0)",
    )
    group.addoption(
        "--mcs-competition",
        dest="mcs_competition",
        action="append",
        default=None,
        metavar="DIR",
        help="collect the UAV test competition's cases in DIR and below (YAML files with "
        "drone: and simulation:, as its test generators write them); repeatable",
    )
    parser.addini("mcs_fidelity", "default for --mcs-fidelity", default="low")
    parser.addini("mcs_placement", "default for --mcs-placement", default="")
    parser.addini("mcs_seed", "default for --mcs-seed", default="0")
    parser.addini("mcs_artifacts", "default for --mcs-artifacts", default=_ARTIFACTS_DEFAULT)
    parser.addini("mcs_keep_traces", "default for --mcs-keep-traces", default="failed")
    parser.addini("mcs_px4_image", "default for --mcs-px4-image", default="")
    parser.addini("mcs_px4_binary", "default for --mcs-px4-binary", default="")
    parser.addini("mcs_ardupilot_dir", "default for --mcs-ardupilot-dir", default="")
    parser.addini("mcs_aerobench_dir", "default for --mcs-aerobench-dir", default="")
    parser.addini("mcs_ray", "default for --mcs-ray", default="")
    parser.addini("mcs_repeat", "default for --mcs-repeat", default="1")
    parser.addini("mcs_repeat_load", "default for --mcs-repeat-load", default="0")
    parser.addini(
        "mcs_competition", "default for --mcs-competition (folders)", type="paths", default=[]
    )


def given(config: pytest.Config) -> bool:
    """Whether any option of the group that widens the plugin's reach was given."""
    return any(config.getoption(dest) is not None for dest in OPTION_DESTS)


def _value(config: pytest.Config, name: str) -> tuple[str, str]:
    """The option's value (the command line wins over the ini file) and where it came from."""
    option = config.getoption(name)
    if option is not None:
        return str(option).strip(), "--" + name.replace("_", "-")
    ini = config.inipath.name if config.inipath is not None else "the ini file"
    return str(config.getini(name)).strip(), f"{name} (in {ini})"


def parse_fidelity(text: str, source: str = "--mcs-fidelity") -> tuple[str, ...]:
    """Parse a comma list of fidelity levels; raise UsageError naming the allowed values."""
    levels = tuple(part.strip() for part in text.split(","))
    bad = [level for level in levels if level not in FIDELITIES]
    if bad:
        # An empty item ("low,,medium", "low,") is refused too: a typo, not a level.
        named = ", ".join("an empty item" if not level else repr(level) for level in bad)
        raise pytest.UsageError(
            f"{source}: {text!r} names no known fidelity level ({named}); "
            f"allowed: {', '.join(FIDELITIES)} (or a comma list of them)"
        )
    return tuple(dict.fromkeys(levels))


def _unwritable(path: Path) -> str | None:
    """Why ``path`` cannot be (or become) a writable directory, or None if it can.

    Probes by creating (and removing) a directory where it would be written, which also
    catches read-only file systems and what permission bits do not show.
    """
    existing = path
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    if not existing.is_dir():
        if existing == path:
            return f"{path} is not a directory"
        return f"the directory {path} cannot be created ({existing} is not a directory)"
    try:
        probe = tempfile.mkdtemp(prefix=".mcs-probe-", dir=existing)
    except OSError as exc:
        why = exc.strerror or str(exc)
        if existing == path:
            return f"cannot write in {path} ({why})"
        return f"the directory {path} cannot be created (making one in {existing} fails: {why})"
    os.rmdir(probe)
    return None


def _artifacts(config: pytest.Config) -> Path:
    text, source = _value(config, "mcs_artifacts")
    artifacts = Path(text)
    if not artifacts.is_absolute():
        # Like pytest's own paths: relative to where pytest was invoked on the command line,
        # relative to the ini file's directory in the ini file.
        if source.startswith("--"):
            base = config.invocation_params.dir
        else:
            base = config.inipath.parent if config.inipath is not None else config.rootpath
        artifacts = base / artifacts
    if source.startswith("--") or text != _ARTIFACTS_DEFAULT:
        # Given on purpose: refuse now what would silently lose traces and logs later.
        problem = _unwritable(artifacts)
        if problem is not None:
            raise pytest.UsageError(
                f"{source}: {text!r} cannot hold traces and logs: {problem}; "
                "allowed: a directory this user can write, or one that can be created"
            )
    return artifacts


def read_settings(config: pytest.Config) -> Settings:
    """The run's settings from its options and ini file; raise UsageError on a bad value."""
    fidelity = parse_fidelity(*_value(config, "mcs_fidelity"))
    placement, source = _value(config, "mcs_placement")
    names = placement_names()
    if placement and placement not in names:
        raise pytest.UsageError(
            f"{source}: {placement!r} is not a registered placement; allowed: "
            f"{', '.join(names)} (the {ENTRY_POINTS!r} entry points)"
        )
    seed_text, source = _value(config, "mcs_seed")
    try:
        seed = int(seed_text)
        if seed < 0:
            raise ValueError
    except ValueError:
        raise pytest.UsageError(
            f"{source}: {seed_text!r} is not a seed; allowed: a non-negative integer"
        ) from None
    keep, source = _value(config, "mcs_keep_traces")
    if keep not in KEEP_TRACES:
        raise pytest.UsageError(
            f"{source}: {keep!r} is not a choice; allowed: {', '.join(KEEP_TRACES)}"
        )
    artifacts = _artifacts(config)
    ray, source = _value(config, "mcs_ray")
    if ray and importlib.util.find_spec("ray") is None:
        raise pytest.UsageError(
            f"{source}: {ray!r} needs Ray, which is not installed: pip install 'multicosim[ray]'"
        )
    repeat = _count(config, "mcs_repeat", 1)
    repeat_load = _count(config, "mcs_repeat_load", 0)
    return Settings(
        fidelity,
        placement or None,
        seed,
        artifacts,
        keep,
        ray or None,
        repeat,
        repeat_load,
        _folders(config),
    )


def _folders(config: pytest.Config) -> tuple[Path, ...]:
    """The competition's folders: the command line's (relative to where pytest was invoked),
    else the ini file's (relative to it)."""
    given_dirs: list[str] | None = config.getoption("mcs_competition")
    if given_dirs:
        source = "--mcs-competition"
        folders = [config.invocation_params.dir / d for d in given_dirs]
    else:
        source = "mcs_competition (in the ini file)"
        folders = [Path(p) for p in config.getini("mcs_competition")]
    for folder in folders:
        if not folder.is_dir():
            raise pytest.UsageError(
                f"{source}: {str(folder)!r} is not a folder; allowed: a folder of the UAV test "
                "competition's cases (YAML files with drone: and simulation:)"
            )
    return tuple(folder.absolute() for folder in folders)


def _count(config: pytest.Config, name: str, least: int) -> int:
    text, source = _value(config, name)
    try:
        count = int(text)
        if count < least:
            raise ValueError
    except ValueError:
        raise pytest.UsageError(
            f"{source}: {text!r} is not a count; allowed: an integer >= {least}"
        ) from None
    return count
