"""The multicosim pytest plugin: options, the ``fidelity`` marker, core fixtures, reports.

Installed packages activate it through the ``pytest11`` entry point. Options live in the
``multicosim`` group, each with an ini twin (``mcs_fidelity = low,medium`` in ``pytest.ini``).
"""

from __future__ import annotations

import atexit
import dataclasses
import importlib.util
import logging
import re
import shlex
import shutil
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any, TypeVar

import pytest

from multicosim._errors import MulticosimError

__all__ = [
    "BACKENDS",
    "FIDELITY_LEVELS",
    "FIXTURE_LIBRARIES",
    "KEEP_TRACES",
    "Settings",
    "SimulationRegistry",
]

log = logging.getLogger(__name__)

FIDELITY_LEVELS = ("low", "medium", "high")
BACKENDS = ("process", "docker")
KEEP_TRACES = ("failed", "all", "none")
FIXTURE_LIBRARIES = (
    "pytest_multicosim.rover",
    "pytest_multicosim.px4",
    "pytest_multicosim.gps_noise",
)

SimT = TypeVar("SimT")


@dataclasses.dataclass(frozen=True)
class Settings:
    """The validated multicosim options of a pytest run."""

    fidelity: tuple[str, ...]
    backend: str
    seed: int
    artifacts: Path
    keep_traces: str

    def replay_args(self, fidelity: str | None) -> str:
        """Command-line options that replay a test with the same seed and fidelity."""
        level = fidelity or ",".join(self.fidelity)
        return f"--mcs-seed={self.seed} --mcs-fidelity={level} --mcs-backend={self.backend}"


settings_key = pytest.StashKey[Settings]()
registry_key = pytest.StashKey["SimulationRegistry"]()


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("multicosim", "multicosim co-simulation")
    group.addoption(
        "--mcs-fidelity",
        dest="mcs_fidelity",
        default=None,
        help="fidelity level(s) to run: low, medium, high, or a comma list (default: low)",
    )
    group.addoption(
        "--mcs-backend",
        dest="mcs_backend",
        default=None,
        help="where components run: process (default) or docker",
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
    parser.addini("mcs_fidelity", "default for --mcs-fidelity", default="low")
    parser.addini("mcs_backend", "default for --mcs-backend", default="process")
    parser.addini("mcs_seed", "default for --mcs-seed", default="0")
    parser.addini("mcs_artifacts", "default for --mcs-artifacts", default="mcs-artifacts")
    parser.addini("mcs_keep_traces", "default for --mcs-keep-traces", default="failed")


def _value(config: pytest.Config, name: str) -> tuple[str, str]:
    """The option's value (the command line wins over the ini file) and where it came from."""
    option = config.getoption(name)
    if option is not None:
        return str(option).strip(), "--" + name.replace("_", "-")
    ini = config.inipath.name if config.inipath is not None else "the ini file"
    return str(config.getini(name)).strip(), f"{name} (in {ini})"


def parse_fidelity(text: str, source: str = "--mcs-fidelity") -> tuple[str, ...]:
    """Parse a comma list of fidelity levels; raise UsageError naming the allowed values."""
    levels = tuple(part.strip() for part in text.split(",") if part.strip())
    bad = [level for level in levels if level not in FIDELITY_LEVELS]
    if not levels or bad:
        raise pytest.UsageError(
            f"{source}: {text!r} names no known fidelity level "
            f"({', '.join(map(repr, bad)) or 'none given'}); "
            f"allowed: {', '.join(FIDELITY_LEVELS)} (or a comma list of them)"
        )
    return tuple(dict.fromkeys(levels))


def _settings(config: pytest.Config) -> Settings:
    fidelity = parse_fidelity(*_value(config, "mcs_fidelity"))
    backend, source = _value(config, "mcs_backend")
    if backend not in BACKENDS:
        raise pytest.UsageError(
            f"{source}: {backend!r} is not a backend; allowed: {', '.join(BACKENDS)}"
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
    artifacts_text, source = _value(config, "mcs_artifacts")
    artifacts = Path(artifacts_text)
    if not artifacts.is_absolute():
        # Like pytest's own paths: relative to where pytest was invoked on the command line,
        # relative to the ini file's directory in the ini file.
        if source.startswith("--"):
            base = config.invocation_params.dir
        else:
            base = config.inipath.parent if config.inipath is not None else config.rootpath
        artifacts = base / artifacts
    return Settings(fidelity, backend, seed, artifacts, keep)


@pytest.hookimpl(tryfirst=True)
def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "fidelity(*levels): run the test at these fidelity levels only (low, medium, high); "
        "skipped with the reason at the other selected levels",
    )
    config.stash[settings_key] = _settings(config)
    # The scenario fixture libraries: registered when present (they import heavy
    # dependencies only inside their fixtures).
    for name in FIXTURE_LIBRARIES:
        if importlib.util.find_spec(name) is not None and not config.pluginmanager.has_plugin(name):
            config.pluginmanager.import_plugin(name)
    registry = SimulationRegistry()
    config.stash[registry_key] = registry
    # Safety net for interpreter exits that bypass fixture teardown.
    atexit.register(registry.stop_all)


def pytest_unconfigure(config: pytest.Config) -> None:
    registry = config.stash.get(registry_key, None)
    if registry is not None:
        registry.stop_all()


def pytest_sessionstart(session: pytest.Session) -> None:
    from multicosim._local import sweep_stale_runs

    killed = sweep_stale_runs()
    if killed:
        log.warning("removed %d process group(s) left by killed runs", len(killed))


def pytest_report_header(config: pytest.Config) -> str:
    s = config.stash[settings_key]
    return (
        f"multicosim: fidelity={','.join(s.fidelity)} backend={s.backend} seed={s.seed} "
        f"keep-traces={s.keep_traces} artifacts={s.artifacts}"
    )


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    marker = metafunc.definition.get_closest_marker("fidelity")
    if marker is None and "mcs_fidelity" not in metafunc.fixturenames:
        return
    settings = metafunc.config.stash[settings_key]
    listed: tuple[str, ...] = FIDELITY_LEVELS
    if marker is not None:
        # A collection error names the test and its marker without a traceback through
        # pytest's internals; the run stops like on any other collection error.
        args = ", ".join(map(repr, marker.args))
        where = f"@pytest.mark.fidelity({args}) on {metafunc.definition.nodeid}"
        if not marker.args or not all(isinstance(a, str) for a in marker.args):
            raise pytest.Collector.CollectError(
                f"{where}: give one or more levels as strings; "
                f"allowed: {', '.join(FIDELITY_LEVELS)}"
            )
        try:
            listed = parse_fidelity(",".join(marker.args), source=where)
        except pytest.UsageError as exc:
            raise pytest.Collector.CollectError(str(exc)) from None
        if "mcs_fidelity" not in metafunc.fixturenames:
            metafunc.fixturenames.append("mcs_fidelity")
    params = [
        pytest.param(
            level,
            id=level,
            marks=()
            if level in listed
            else pytest.mark.skip(
                reason=f"fidelity {level!r} not in the test's levels ({', '.join(listed)})"
            ),
        )
        for level in settings.fidelity
    ]
    metafunc.parametrize("mcs_fidelity", params, scope="function")


# -- fixtures -------------------------------------------------------------------------------


@pytest.fixture
def mcs_settings(request: pytest.FixtureRequest) -> Settings:
    """The validated multicosim options of this run."""
    return request.config.stash[settings_key]


@pytest.fixture
def mcs_fidelity(request: pytest.FixtureRequest) -> str:
    """The fidelity level this test runs at (tests run once per selected level)."""
    return str(getattr(request, "param", request.config.stash[settings_key].fidelity[0]))


@pytest.fixture
def mcs_backend(mcs_settings: Settings) -> str:
    """The selected backend: ``process`` or ``docker``."""
    return mcs_settings.backend


@pytest.fixture
def mcs_seed(mcs_settings: Settings) -> int:
    """The seed that fixes every random source of this test's simulations."""
    return mcs_settings.seed


class SimulationRegistry:
    """Simulations started for tests; each is stopped at teardown whatever happens."""

    def __init__(self) -> None:
        self._live: list[Any] = []

    def track(self, simulation: SimT) -> SimT:
        """Stop ``simulation`` at the end of the test (or of the run, on interruption)."""
        self._live.append(simulation)
        return simulation

    def start(self, simulator: Any) -> Any:
        """Start ``simulator`` and track its simulation."""
        return self.track(simulator.start())

    @property
    def live(self) -> list[Any]:
        """Simulations not yet stopped."""
        return list(self._live)

    def stop(self, simulations: list[Any]) -> None:
        """Stop ``simulations`` (newest first); raise every failure together."""
        from multicosim._simulation import stop_all

        steps = []
        for sim in reversed(simulations):
            if sim in self._live:
                self._live.remove(sim)
                steps.append((f"simulation {sim!r}", sim.stop))
        stop_all(steps, "the test's simulations")

    def stop_all(self) -> None:
        """Stop every live simulation, logging failures (used at exit)."""
        try:
            self.stop(list(self._live))
        except BaseException as exc:  # at exit nothing can be raised to a test any more
            log.warning("stopping leftover simulations failed: %r", exc)


class _TestSimulations:
    """The per-test view of the registry, the object behind the ``mcs_simulations`` fixture."""

    def __init__(self, registry: SimulationRegistry) -> None:
        self._registry = registry
        self.simulations: list[Any] = []

    def track(self, simulation: SimT) -> SimT:
        """Stop ``simulation`` when the test ends."""
        self.simulations.append(self._registry.track(simulation))
        return simulation

    def start(self, simulator: Any) -> Any:
        """Start ``simulator`` and stop its simulation when the test ends."""
        return self.track(simulator.start())

    def close(self) -> None:
        self._registry.stop(self.simulations)


@pytest.fixture
def mcs_simulations(request: pytest.FixtureRequest) -> Iterator[_TestSimulations]:
    """Starts simulations for the test and stops them at teardown, even after a failure."""
    view = _TestSimulations(request.config.stash[registry_key])
    request.node.stash[_view_key] = view
    try:
        yield view
    finally:
        view.close()


_view_key = pytest.StashKey[_TestSimulations]()


class _TrackedSimulator:
    """A simulator whose simulations the test stops at teardown."""

    def __init__(self, inner: Any, view: _TestSimulations) -> None:
        self._inner = inner
        self._view = view

    def add(self, component: Any) -> Any:
        """Add ``component`` to the wrapped simulator."""
        return self._inner.add(component)

    def start(self) -> Any:
        """Start the simulation; it is stopped when the test ends."""
        return self._view.start(self._inner)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


@pytest.fixture
def mcs_simulator(
    mcs_backend: str, mcs_seed: int, mcs_simulations: _TestSimulations
) -> _TrackedSimulator:
    """A fresh simulator of the selected backend, seeded; its simulation always stops."""
    if mcs_backend == "docker":
        docker_backend = importlib.import_module("multicosim.docker")
        inner: Any = docker_backend.ContainerSimulator(seed=mcs_seed)
    else:
        from multicosim._local import ProcessSimulator

        inner = ProcessSimulator(seed=mcs_seed)
    return _TrackedSimulator(inner, mcs_simulations)


# -- reports --------------------------------------------------------------------------------


def _slug(nodeid: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", nodeid).strip("_")[:150]


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    report: pytest.TestReport = yield
    if not report.failed:
        return report
    settings = item.config.stash[settings_key]
    fidelity = None
    callspec = getattr(item, "callspec", None)
    if callspec is not None:
        fidelity = callspec.params.get("mcs_fidelity")
    lines = [
        f"seed {settings.seed}, fidelity {fidelity or ','.join(settings.fidelity)}, "
        f"backend {settings.backend}",
        # Quoted for a POSIX shell: parametrized ids may hold quotes, spaces or brackets.
        f"replay: pytest {shlex.quote(item.nodeid)} {settings.replay_args(fidelity)}",
    ]
    view = item.stash.get(_view_key, None)
    if view is not None and settings.keep_traces != "none":
        saved = _save_logs(view, settings.artifacts / _slug(item.nodeid))
        for name, (path, tail) in saved.items():
            lines.append(f"--- {name}: last output (full log: {path}) ---")
            lines.append(tail)
    report.sections.append(("multicosim", "\n".join(lines)))
    return report


def _save_logs(view: _TestSimulations, dest: Path) -> dict[str, tuple[Path, str]]:
    saved: dict[str, tuple[Path, str]] = {}
    for sim in view.simulations:
        logs = getattr(sim, "logs", None)
        if logs is None:
            continue
        try:
            files = logs()
        except (OSError, MulticosimError):
            continue
        for name, path in files.items():
            try:
                dest.mkdir(parents=True, exist_ok=True)
                target = dest / path.name
                shutil.copyfile(path, target)
                tail = "\n".join(path.read_text(errors="replace").splitlines()[-20:])
            except OSError:
                continue
            saved[name] = (target, tail)
    return saved
