"""The multicosim pytest plugin: options, the ``fidelity`` marker, core fixtures, reports.

Installed packages load it through the ``pytest11`` entry point, but it acts only for tests
that use its fixtures (``mcs_*`` and the scenario libraries') or the ``fidelity`` marker, or
for every test when an ``--mcs-*`` option is given: only then does it sweep what killed runs
left (processes, and containers where Docker is installed), print its header line, record
traces and add its report section and JUnit properties. Options live in the ``multicosim``
group, each with an ini twin (``mcs_fidelity = low,medium`` in ``pytest.ini``).
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import importlib.util
import logging
import os
import re
import shlex
import shutil
import tempfile
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import pytest

from multicosim.core.errors import MulticosimError
from multicosim.core.fidelity import BACKENDS, FIDELITIES

from ._signals import SigtermAsInterrupt

if TYPE_CHECKING:
    from multicosim.docker import ContainerSimulator
    from multicosim.local import ProcessSimulator

__all__ = [
    "BACKENDS",
    "FIXTURE_LIBRARIES",
    "KEEP_TRACES",
    "Settings",
    "SimulationRegistry",
    "Simulations",
    "docker_unavailable",
    "require_docker",
    "tracked",
]

log = logging.getLogger(__name__)

KEEP_TRACES = ("failed", "all", "none")
_ARTIFACTS_DEFAULT = "mcs-artifacts"
FIXTURE_LIBRARIES = (
    "pytest_multicosim.rover",
    "pytest_multicosim.px4",
    "pytest_multicosim.ardupilot",
    "pytest_multicosim.gps_noise",
    "pytest_multicosim.fmi",
)

SimT = TypeVar("SimT")


StartedT = TypeVar("StartedT", covariant=True)


class _Simulator(Protocol[StartedT]):
    def start(self) -> StartedT: ...


SimulatorT = TypeVar("SimulatorT", bound=_Simulator[Any])


@dataclasses.dataclass(frozen=True)
class Settings:
    """The validated multicosim options of a pytest run."""

    fidelity: tuple[str, ...]
    backend: str
    seed: int
    artifacts: Path
    keep_traces: str
    ray: str | None = None

    def replay_args(self, fidelity: str | None) -> str:
        """Command-line options that replay a test with the same seed and fidelity."""
        level = fidelity or ",".join(self.fidelity)
        return f"--mcs-seed={self.seed} --mcs-fidelity={level} --mcs-backend={self.backend}"


settings_key = pytest.StashKey[Settings]()
registry_key = pytest.StashKey["SimulationRegistry"]()
activity_key = pytest.StashKey["_Activity"]()
# Every option of the group: giving any of them on the command line (or in addopts) makes
# the plugin act for every test of the session.
OPTION_DESTS = (
    "mcs_fidelity",
    "mcs_backend",
    "mcs_seed",
    "mcs_artifacts",
    "mcs_keep_traces",
    "mcs_px4_image",
    "mcs_px4_binary",
    "mcs_ray",
)


@dataclasses.dataclass
class _Activity:
    """Whether the plugin acts in this session, and what it has done once already."""

    explicit: bool  # an --mcs-* option was given: act for every test
    fixtures: frozenset[str]  # the fixtures we provide (a test using one is ours)
    swept: bool = False


sigterm_key = pytest.StashKey[SigtermAsInterrupt]()


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
        "--mcs-ray",
        dest="mcs_ray",
        default=None,
        help="run campaigns (mcs_campaign_executor) on the Ray cluster at ADDRESS "
        "(auto, local, ray://head:10001, ...; default: the local process pool)",
    )
    parser.addini("mcs_fidelity", "default for --mcs-fidelity", default="low")
    parser.addini("mcs_backend", "default for --mcs-backend", default="process")
    parser.addini("mcs_seed", "default for --mcs-seed", default="0")
    parser.addini("mcs_artifacts", "default for --mcs-artifacts", default=_ARTIFACTS_DEFAULT)
    parser.addini("mcs_keep_traces", "default for --mcs-keep-traces", default="failed")
    parser.addini("mcs_px4_image", "default for --mcs-px4-image", default="")
    parser.addini("mcs_px4_binary", "default for --mcs-px4-binary", default="")
    parser.addini("mcs_ardupilot_dir", "default for --mcs-ardupilot-dir", default="")
    parser.addini("mcs_ray", "default for --mcs-ray", default="")


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
    bad = [level for level in levels if level not in FIDELITIES]
    if not levels or bad:
        raise pytest.UsageError(
            f"{source}: {text!r} names no known fidelity level "
            f"({', '.join(map(repr, bad)) or 'none given'}); "
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
        return f"{existing} is not a directory"
    try:
        probe = tempfile.mkdtemp(prefix=".mcs-probe-", dir=existing)
    except OSError as exc:
        return f"cannot write in {existing} ({exc.strerror or exc})"
    os.rmdir(probe)
    return None


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
    if source.startswith("--") or artifacts_text != _ARTIFACTS_DEFAULT:
        # Given on purpose: refuse now what would silently lose traces and logs later.
        problem = _unwritable(artifacts)
        if problem is not None:
            raise pytest.UsageError(
                f"{source}: {artifacts_text!r} cannot hold traces and logs: {problem}; "
                "allowed: a directory this user can write, or one that can be created"
            )
    ray, source = _value(config, "mcs_ray")
    if ray and importlib.util.find_spec("ray") is None:
        raise pytest.UsageError(
            f"{source}: {ray!r} needs Ray, which is not installed: pip install 'multicosim[ray]'"
        )
    return Settings(fidelity, backend, seed, artifacts, keep, ray or None)


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
    config.stash[activity_key] = _Activity(
        explicit=any(config.getoption(dest) is not None for dest in OPTION_DESTS),
        fixtures=_our_fixtures(),
    )
    config.stash[sigterm_key] = SigtermAsInterrupt()
    # Safety net for interpreter exits that bypass fixture teardown.
    atexit.register(registry.stop_all)


def _our_fixtures() -> frozenset[str]:
    """Names of the fixtures this plugin and its fixture libraries define."""
    import importlib
    import sys

    modules = [sys.modules[__name__]]
    for name in FIXTURE_LIBRARIES:
        if importlib.util.find_spec(name) is not None:
            modules.append(importlib.import_module(name))
    found: set[str] = set()
    for module in modules:
        for attr, value in vars(module).items():
            if type(value).__name__ == "FixtureFunctionDefinition":
                found.add(getattr(value, "name", None) or attr)
    return frozenset(found)


def acts_for(item: pytest.Item) -> bool:
    """Whether the plugin acts for ``item`` (our fixtures or marker, or an option given)."""
    activity = item.config.stash[activity_key]
    if activity.explicit or item.get_closest_marker("fidelity") is not None:
        return True
    return not activity.fixtures.isdisjoint(getattr(item, "fixturenames", ()))


def pytest_unconfigure(config: pytest.Config) -> None:
    sigterm = config.stash.get(sigterm_key, None)
    if sigterm is not None:
        sigterm.uninstall()
    registry = config.stash.get(registry_key, None)
    if registry is not None:
        registry.stop_all()
        # The safety net is no longer needed; in-process runs (pytester) would pile them up.
        atexit.unregister(registry.stop_all)


def pytest_sessionstart(session: pytest.Session) -> None:
    activity = session.config.stash[activity_key]
    if activity.explicit:
        _sweep_once(activity)
    # Otherwise the first test that uses our fixtures or marker sweeps (pytest_runtest_protocol):
    # a session of unrelated tests never looks for processes or contacts the Docker engine.


def _sweep_once(activity: _Activity) -> None:
    if activity.swept:
        return
    activity.swept = True
    from multicosim.local import sweep_stale_runs

    killed = sweep_stale_runs()
    if killed:
        log.warning("removed %d process group(s) left by killed runs", len(killed))
    if not _nested():
        _sweep_docker()


def pytest_sessionfinish(session: pytest.Session) -> None:
    # Only this session's leftovers: under xdist another worker may still be running a test
    # that looks at what a killed run left.
    activity = session.config.stash.get(activity_key, None)
    if activity is not None and activity.swept and not _nested():
        _sweep_docker(only_current_process=True)


def _nested() -> bool:
    # A session run inside a test (pytester, inline or as a subprocess) leaves the engine
    # alone: the outer test may be looking at what a killed run left on purpose.
    return os.environ.get("PYTEST_CURRENT_TEST") is not None


def _sweep_docker(*, only_current_process: bool = False) -> None:
    if importlib.util.find_spec("docker") is None:
        return
    from multicosim.docker import sweep

    report = sweep(only_current_process=only_current_process)
    if report.containers or report.networks:
        log.warning("docker sweep: %s", report.summary())


def _header(config: pytest.Config) -> str:
    s = config.stash[settings_key]
    return (
        f"multicosim: fidelity={','.join(s.fidelity)} backend={s.backend} seed={s.seed} "
        f"keep-traces={s.keep_traces} artifacts={s.artifacts}"
    )


def pytest_report_header(config: pytest.Config) -> str | None:
    return _header(config) if config.stash[activity_key].explicit else None


def pytest_report_collectionfinish(
    config: pytest.Config, start_path: Path, items: list[pytest.Item]
) -> str | None:
    # Without an option the header waits for collection: only a suite with tests of ours shows it.
    if config.stash[activity_key].explicit or not any(acts_for(item) for item in items):
        return None
    return _header(config)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    marker = metafunc.definition.get_closest_marker("fidelity")
    wanted = {"mcs_fidelity", "mcs_fresh_simulation"} & set(metafunc.fixturenames)
    if marker is None and not wanted:
        return
    settings = metafunc.config.stash[settings_key]
    listed: tuple[str, ...] = FIDELITIES
    if marker is not None:
        # A collection error names the test and its marker without a traceback through
        # pytest's internals; the run stops like on any other collection error.
        args = ", ".join(map(repr, marker.args))
        where = f"@pytest.mark.fidelity({args}) on {metafunc.definition.nodeid}"
        if not marker.args or not all(isinstance(a, str) for a in marker.args):
            raise pytest.Collector.CollectError(
                f"{where}: give one or more levels as strings; allowed: {', '.join(FIDELITIES)}"
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
    # Session scope: Hypothesis accepts it in @given tests (it is the same for every
    # example), and tests are grouped by level.
    metafunc.parametrize("mcs_fidelity", params, scope="session")


# -- fixtures -------------------------------------------------------------------------------


@pytest.fixture(scope="session")
def mcs_settings(request: pytest.FixtureRequest) -> Settings:
    """The validated multicosim options of this run."""
    return request.config.stash[settings_key]


@pytest.fixture
def mcs_fidelity(request: pytest.FixtureRequest) -> str:
    """The fidelity level this test runs at (tests run once per selected level)."""
    return str(getattr(request, "param", request.config.stash[settings_key].fidelity[0]))


@pytest.fixture(scope="session")
def mcs_backend(mcs_settings: Settings) -> str:
    """The selected backend: ``process`` or ``docker``."""
    return mcs_settings.backend


@pytest.fixture(scope="session")
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
        from multicosim.local.simulation import stop_all

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


class Simulations:
    """The ``mcs_simulations`` fixture: starts simulations and stops them when the test ends."""

    def __init__(self, registry: SimulationRegistry) -> None:
        self._registry = registry
        self.simulations: list[Any] = []

    def track(self, simulation: SimT) -> SimT:
        """Stop ``simulation`` when the test ends (and record it for the test's trace)."""
        self.simulations.append(self._registry.track(simulation))
        from multicosim import trace

        test_trace = trace.active()
        if test_trace is not None:
            # A simulation without a simulated clock has nothing to record.
            with contextlib.suppress(MulticosimError):
                test_trace.attach(simulation)
        return simulation

    def start(self, simulator: _Simulator[StartedT]) -> StartedT:
        """Start ``simulator`` and stop its simulation when the test ends."""
        return self.track(simulator.start())

    def close(self) -> None:
        self._registry.stop(self.simulations)


@pytest.fixture
def mcs_simulations(request: pytest.FixtureRequest) -> Iterator[Simulations]:
    """Starts simulations for the test and stops them at teardown, even after a failure.

    From the first use on, SIGTERM stops the run as Ctrl-C does, with teardown.
    """
    request.config.stash[sigterm_key].install()
    view = Simulations(request.config.stash[registry_key])
    request.node.stash[_view_key] = view
    try:
        yield view
    finally:
        view.close()


_view_key = pytest.StashKey[Simulations]()


def tracked(simulator: SimulatorT, simulations: Simulations) -> SimulatorT:
    """``simulator`` itself, whose ``start`` hands each simulation to ``simulations``.

    The fixtures return the simulator itself, not a proxy, so that it is an instance of its
    own class; what it starts is stopped (and recorded) as the test ends.
    """
    start = simulator.start

    def start_tracked() -> Any:
        return simulations.track(start())

    # An instance attribute, not a method assignment: it shadows the class's own start.
    setattr(simulator, "start", start_tracked)  # noqa: B010
    return simulator


def require_docker() -> None:
    """Skip the test, with the reason, unless a Docker engine answers.

    With ``MCS_REQUIRE_DOCKER=1`` (CI) a missing engine fails the test instead.
    """
    try:
        from multicosim.docker import engine_available
    except ImportError as exc:  # the docker extra is missing (DependencyMissingError)
        docker_unavailable("no Docker SDK (pip install 'multicosim[docker]')", str(exc))
    reason = engine_available()
    if reason is not None:
        from multicosim.docker.engine import engine_url

        docker_unavailable(f"no Docker engine at {engine_url()}", reason)


def docker_unavailable(reason: str, detail: str = "") -> None:
    """Skip with the one-line ``reason``; fail, with ``detail``, under MCS_REQUIRE_DOCKER=1."""
    # Read when needed, not at import: a test may set it for a pytester run.
    if os.environ.get("MCS_REQUIRE_DOCKER") == "1":
        pytest.fail(f"MCS_REQUIRE_DOCKER=1 but {reason}: {detail}", pytrace=False)
    pytest.skip(reason)


@pytest.fixture(scope="session")
def mcs_runtime_image() -> str:
    """The runtime image that docker-backed scenarios run, rebuilt if the source changed.

    Skips (or, with ``MCS_REQUIRE_DOCKER=1``, fails) the test where no engine runs. An
    installed package cannot build it: it must then be present locally.
    """
    require_docker()
    from multicosim.docker import RUNTIME_IMAGE, build_images
    from multicosim.docker.engine import ImageNotFound, client

    try:
        return build_images()[0]
    except MulticosimError as exc:
        try:
            client().api.inspect_image(RUNTIME_IMAGE)
        except ImageNotFound:
            docker_unavailable(f"{RUNTIME_IMAGE} could not be built", str(exc))
        log.warning("using %s as it is: %s", RUNTIME_IMAGE, exc)
        return RUNTIME_IMAGE


@pytest.fixture
def mcs_simulator(
    mcs_backend: str, mcs_seed: int, mcs_simulations: Simulations
) -> ProcessSimulator | ContainerSimulator:
    """A fresh simulator of the selected backend, seeded; its simulation always stops."""
    if mcs_backend == "docker":
        require_docker()
        from multicosim.docker import ContainerSimulator

        inner: ProcessSimulator | ContainerSimulator = ContainerSimulator(seed=mcs_seed)
    else:
        from multicosim.local import ProcessSimulator

        inner = ProcessSimulator(seed=mcs_seed)
    return tracked(inner, mcs_simulations)


@pytest.fixture(scope="session")
def mcs_campaign_executor(mcs_settings: Settings) -> Iterator[Any]:
    """The executor campaigns use: the Ray cluster of ``--mcs-ray``, else the process pool.

    Pass it on: ``run_campaign(simulate, requirement, design, executor=mcs_campaign_executor)``.
    A Ray connection is made on first use and closed at the end of the session.
    """
    from multicosim.search.campaign import ProcessExecutor, RayExecutor

    if mcs_settings.ray is None:
        yield ProcessExecutor()
        return
    executor = RayExecutor(mcs_settings.ray)
    try:
        yield executor
    finally:
        executor.shutdown()


@pytest.fixture(scope="session")
def mcs_fresh_simulation() -> Any:
    """A new simulation per Hypothesis example, stopped when the example ends.

    Session-scoped on purpose: Hypothesis rejects function-scoped fixtures in ``@given``
    tests because they are not reset between examples::

        @given(mission=rover.strategies.missions())
        def test_x(mcs_fresh_simulation, mission):
            with mcs_fresh_simulation(rover.Rover) as simulation: ...
    """
    from multicosim.search.strategies import FreshSimulations

    return FreshSimulations()


# -- traces and reports ---------------------------------------------------------------------

trace_key = pytest.StashKey[Any]()
dest_key = pytest.StashKey[Path]()


def _fidelity_of(item: pytest.Item) -> str | None:
    callspec = getattr(item, "callspec", None)
    return None if callspec is None else callspec.params.get("mcs_fidelity")


def artifacts_dir(settings: Settings, item: pytest.Item) -> Path:
    """Where the artifacts of ``item`` go: one directory per test, seed and backend.

    A replay with another seed (or backend) writes beside the original failure's files, not
    over them.
    """
    return settings.artifacts / _slug(item.nodeid) / f"seed-{settings.seed}-{settings.backend}"


def replay_command(settings: Settings, item: pytest.Item) -> str:
    """The command that runs ``item`` again with the same seed, fidelity and backend.

    The test is named by its absolute path, so the command works from any directory.
    """
    _, sep, rest = item.nodeid.partition("::")
    target = str(item.path) + (sep + rest if sep else "")
    # Quoted for a POSIX shell: parametrized ids may hold quotes, spaces or brackets.
    return f"pytest {shlex.quote(target)} {settings.replay_args(_fidelity_of(item))}"


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(
    item: pytest.Item, nextitem: pytest.Item | None
) -> Generator[None, object, object]:
    # From the first fixture's setup to the last teardown: simulations that fixtures start
    # are recorded too.
    if not acts_for(item):
        return (yield)
    _sweep_once(item.config.stash[activity_key])
    from multicosim import trace

    settings = item.config.stash[settings_key]
    dest = artifacts_dir(settings, item)
    # What an earlier run of this test left must not pass for this run's.
    shutil.rmtree(dest, ignore_errors=True)
    item.stash[dest_key] = dest
    test_trace = trace.TestTrace(
        metadata={
            "test": item.nodeid,
            "seed": settings.seed,
            "fidelity": _fidelity_of(item) or settings.fidelity[0],
            "backend": settings.backend,
        },
        record=settings.keep_traces != "none",
    )
    item.stash[trace_key] = test_trace
    with trace.activate(test_trace):
        return (yield)


def _save_trace(
    item: pytest.Item, call: pytest.CallInfo[None], dest: Path, replay: str
) -> tuple[list[Path], str | None]:
    """Save the test's traces; return the written paths, or why nothing could be written."""
    test_trace = item.stash.get(trace_key, None)
    if test_trace is None:
        return [], None
    from multicosim import trace

    example = None
    if call.excinfo is not None:
        example = trace.falsifying_example(call.excinfo.value)
    # The recording ends with the call: what teardown routes is not part of the failure.
    test_trace.detach()
    try:
        saved: list[Path] = test_trace.save(dest, failing_example=example, replay=replay)
    except Exception as exc:  # a trace is a diagnosis aid: never turn a report into a crash
        log.warning("could not save the trace of %s: %s", item.nodeid, exc)
        return [], f"{type(exc).__name__}: {exc}"
    return saved, None


def _slug(nodeid: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", nodeid).strip("_")[:150]


_KINDS = {".mcap": "trace", ".json": "layout", ".tlog": "mavlink", ".png": "plot"}


def _verdict(item: pytest.Item, call: pytest.CallInfo[None]) -> str:
    """One line: what failed, and for a requirement where it was first violated."""
    if call.excinfo is None:
        return "failed"
    text = call.excinfo.exconly().strip().splitlines()
    line = text[0] if text else call.excinfo.typename
    test_trace = item.stash.get(trace_key, None)
    evaluation = getattr(test_trace, "evaluation", None)
    first = getattr(evaluation, "first_violation", None)
    if first is not None:
        line += f"; first violated at t={first:.6g} s"
    return line


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    report: pytest.TestReport = yield
    if not acts_for(item):
        return report
    settings = item.config.stash[settings_key]
    fidelity = _fidelity_of(item)
    replay = replay_command(settings, item)
    dest = item.stash.get(dest_key, None) or artifacts_dir(settings, item)
    keep = settings.keep_traces != "none"
    saved: list[Path] = []
    if not report.failed:
        # --mcs-keep-traces=all keeps what passing tests left too (without a report section).
        if settings.keep_traces == "all" and report.when == "call":
            passed_view = item.stash.get(_view_key, None)
            if passed_view is not None:
                _save_logs(passed_view, dest)
            saved, _ = _save_trace(item, call, dest, replay)
            _properties(item, settings, replay, saved)
        return report
    problem = None
    if keep and report.when in ("setup", "call"):
        saved, problem = _save_trace(item, call, dest, replay)
    # JUnit XML (and other report readers) get the same facts as properties; they are read
    # from the item when the teardown report is made.
    _properties(item, settings, replay, saved)
    lines = [f"verdict: {_verdict(item, call)}", f"replay: {replay}"]
    lines.extend(f"{_KINDS.get(path.suffix, 'file')}: {path}" for path in saved)
    if problem is not None:
        lines.append(f"trace: not saved ({problem})")
    mcap = next((p for p in saved if p.suffix == ".mcap"), None)
    layout = next((p for p in saved if p.suffix == ".json"), None)
    if mcap is not None and layout is not None:
        lines.append(
            f"open: Foxglove (app or web) > Open local file... {mcap.name}, then "
            f"Layout > Import from file... {layout.name}"
        )
    lines.append(
        f"seed {settings.seed}, fidelity {fidelity or ','.join(settings.fidelity)}, "
        f"backend {settings.backend}"
    )
    view = item.stash.get(_view_key, None)
    if view is not None and keep:
        for name, (path, tail) in _save_logs(view, dest).items():
            lines.append(f"--- {name}: last output (full log: {path}) ---")
            lines.append(tail)
    report.sections.append(("multicosim", "\n".join(lines)))
    return report


def _properties(item: pytest.Item, settings: Settings, replay: str, saved: list[Path]) -> None:
    found = [("mcs_seed", str(settings.seed)), ("mcs_replay", replay)]
    found.extend((f"mcs_{_KINDS.get(p.suffix, 'file')}", str(p)) for p in saved)
    item.user_properties.extend(p for p in found if p not in item.user_properties)


_FLIGHT_LOG_VIEWERS = {
    ".ulg": "(ULog: open it in PX4's Flight Review)",
    ".BIN": "(DataFlash log: open it in MAVExplorer or UAV Log Viewer)",
}


def _save_logs(view: Simulations, dest: Path) -> dict[str, tuple[Path, str]]:
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
        # Real firmware's flight logs (binary: copied, not shown): PX4's ULog files, for its
        # Flight Review; ArduPilot's DataFlash logs, for MAVExplorer or UAV Log Viewer.
        flight_logs = getattr(sim, "flight_logs", None)
        try:
            ulogs = flight_logs() if flight_logs is not None else []
        except (OSError, MulticosimError):
            ulogs = []
        for path in ulogs:
            with contextlib.suppress(OSError):
                dest.mkdir(parents=True, exist_ok=True)
                target = dest / path.name
                shutil.copyfile(path, target)
                viewer = _FLIGHT_LOG_VIEWERS.get(path.suffix, "(a flight log)")
                saved[f"flight log {path.name}"] = (target, viewer)
    return saved
