"""The multicosim pytest plugin: its hooks, which hand the work to the modules beside it.

Installed packages load it through the ``pytest11`` entry point, but it acts only for tests
that use its fixtures (``mcs_*`` and the fixture libraries') or the ``fidelity`` marker, or
for every test when an ``--mcs-*`` option is given: only then does it sweep what killed runs
left (processes, and containers where Docker is installed), print its header line, record
traces and add its report section and JUnit properties (``activity``). Options live in
the ``multicosim`` group, each with an ini twin ([`options`][pytest_multicosim.options]); the
fixtures in [`fixtures`][pytest_multicosim.plugin.fixtures] and the libraries of the
``multicosim.fixtures`` entry points (``libraries``) are registered as plugins of their own. Its
state lives in ``config.stash``.
"""

from __future__ import annotations

import atexit
from collections.abc import Generator
from pathlib import Path

import pytest

from . import fixtures, libraries, repeat, scores
from ._signals import SigtermAsInterrupt
from .activity import Activity, activity_key, acts_for, fixture_names, nested
from .artifacts import recording
from .docker import sweep_containers
from .fidelity import MARKER, deselect, deselected_key, parametrize, unlisted
from .fixtures import sigterm_key
from .options import add_options, given, read_settings, settings_key
from .reports import annotate, header
from .simulations import SimulationRegistry, registry_key

__all__: list[str] = []  # hooks only: the names to import live in the modules beside it


def pytest_addoption(parser: pytest.Parser) -> None:
    add_options(parser)


@pytest.hookimpl(tryfirst=True)
def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", MARKER)
    config.stash[settings_key] = read_settings(config)
    if not config.pluginmanager.has_plugin(fixtures.__name__):
        config.pluginmanager.register(fixtures, fixtures.__name__)
    # Fixture libraries, ours and other packages' (they import heavy dependencies only
    # inside their fixtures).
    loaded = libraries.load(config)
    registry = SimulationRegistry()
    config.stash[registry_key] = registry
    config.stash[activity_key] = Activity(
        explicit=given(config), fixtures=fixture_names([fixtures, *loaded])
    )
    config.stash[sigterm_key] = SigtermAsInterrupt()
    # Sums up competition-scored flights, if any run (it prints nothing otherwise).
    if not config.pluginmanager.has_plugin(scores.PLUGIN_NAME):
        config.pluginmanager.register(scores.Tally(), scores.PLUGIN_NAME)
    if config.stash[settings_key].repeat > 1 and not config.pluginmanager.has_plugin(
        repeat.PLUGIN_NAME
    ):
        config.pluginmanager.register(repeat.Repeater(config), repeat.PLUGIN_NAME)
    # Safety net for interpreter exits that bypass fixture teardown.
    atexit.register(registry.stop_all)


def pytest_unconfigure(config: pytest.Config) -> None:
    sigterm = config.stash.get(sigterm_key, None)
    if sigterm is not None:
        sigterm.uninstall()
    registry = config.stash.get(registry_key, None)
    if registry is not None:
        registry.stop_all()
        # The safety net is no longer needed; in-process runs (pytester) would pile them up.
        atexit.unregister(registry.stop_all)


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    # Test cases as files (test_*.mcs.yaml): a name no other plugin collects. The module
    # (and the world's types it reads) loads only where there is one.
    if parent.config.stash[settings_key].competition:
        from .competition import CompetitionFile, is_competition_case

        if is_competition_case(file_path, parent.config):
            return CompetitionFile.from_parent(parent, path=file_path)
    if ".mcs." not in file_path.name:
        return None
    from .cases import CaseFile, is_case

    return CaseFile.from_parent(parent, path=file_path) if is_case(file_path) else None


def pytest_sessionstart(session: pytest.Session) -> None:
    activity = session.config.stash[activity_key]
    if activity.explicit:
        activity.sweep_once()
    # Otherwise the first test that uses our fixtures or marker sweeps (pytest_runtest_protocol):
    # a session of unrelated tests never looks for processes or contacts the Docker engine.


def pytest_sessionfinish(session: pytest.Session) -> None:
    # Only this session's leftovers: under xdist another worker may still be running a test
    # that looks at what a killed run left.
    activity = session.config.stash.get(activity_key, None)
    if activity is not None and activity.swept and not nested():
        sweep_containers(only_current_process=True)


def pytest_report_header(config: pytest.Config) -> str | None:
    return header(config) if config.stash[activity_key].explicit else None


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    parametrize(metafunc)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    deselect(config, items, unlisted)


def pytest_report_collectionfinish(
    config: pytest.Config, start_path: Path, items: list[pytest.Item]
) -> list[str]:
    lines: list[str] = []
    # Without an option the header waits for collection: only a suite with tests of ours shows it.
    if not config.stash[activity_key].explicit and any(acts_for(item) for item in items):
        lines.append(header(config))
    # One line for the tests deselected at levels they never run at (their marker's, real
    # firmware's): a skip then always means that something a test needed was missing.
    count = config.stash.get(deselected_key, 0)
    if count:
        lines.append(f"multicosim: {count} deselected at fidelity levels they never run at")
    return lines


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(
    item: pytest.Item, nextitem: pytest.Item | None
) -> Generator[None, object, object]:
    # From the first fixture's setup to the last teardown: simulations that fixtures start
    # are recorded too.
    if not acts_for(item):
        return (yield)
    item.config.stash[activity_key].sweep_once()
    if repeat.repeats(item) > 1:
        return (yield)  # the repeated protocol records each run itself
    with recording(item):
        return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    report: pytest.TestReport = yield
    if acts_for(item):
        if report.when == "call" and repeat.wants_fingerprint(item.config):
            repeat.note_fingerprint(item)
        annotate(item, call, report)
    return report
