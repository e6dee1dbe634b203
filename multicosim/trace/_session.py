"""The traces of one test: a recorder per simulation it starts, active in a context variable."""

from __future__ import annotations

import contextlib
import contextvars
import logging
import threading
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.errors import MulticosimError
from ..local.simulation import add_start_observer
from ._convert import TRAJECTORY_CHANNEL, Converter, trace_options
from ._fingerprint import Fingerprint, fingerprint
from ._recorder import Recorder

if TYPE_CHECKING:
    from ..core.signals import Signals
    from ._recorder import Evaluated

__all__ = ["TestTrace", "activate", "active"]

log = logging.getLogger(__name__)

_current: contextvars.ContextVar[TestTrace | None] = contextvars.ContextVar(
    "multicosim_test_trace", default=None
)


class TestTrace:
    """The traces of one test: a recorder per simulation started in it, plus notes.

    The pytest plugin activates one ([`activate`][multicosim.trace._session.activate]) from the
    setup of a test that uses multicosim's fixtures to its teardown; simulations started through
    ``mcs_simulations`` (and so the scenario fixtures) or a fresh-simulation factory are attached to
    it, and requirement evaluations are noted in it. With ``record=False``
    (``--mcs-keep-traces=none``) it only carries the test's metadata (fidelity, seed) for
    fresh simulations. [`begin_example`][multicosim.trace._session.TestTrace.begin_example] forgets
    what an earlier Hypothesis example recorded, so what is saved is the last (for a failing test:
    the final, minimal) example. With ``record_started`` (a search's trace of one simulation) every
    simulation started while it is active is recorded, however it was started: a scenario's (PX4's,
    the rover's) with its own channels, converters and plot, as in a failing test's trace.
    """

    __test__ = False  # not a pytest test class, despite the name

    def __init__(
        self,
        *,
        metadata: Mapping[str, object] | None = None,
        types: Mapping[str, Any] | None = None,
        converters: Sequence[Converter] = (),
        record: bool = True,
        record_started: bool = False,
    ) -> None:
        self.metadata: dict[str, object] = dict(metadata or {})
        self.record = record
        self.record_started = record_started
        # The recorder of each simulation recorded, by the simulation's id.
        self._sources: dict[int, Recorder] = {}
        # The scenario simulation that wraps a recorded one, by the recorder's id.
        self._wrapped: dict[int, object] = {}
        self.types = dict(types or {})
        self.converters = list(converters)
        self.recorders: list[Recorder] = []
        self.depends_on_firmware = False
        """Whether real firmware's runs (on their own threads) decided what this test holds,
        though they are not among its recordings: a search's confirmations on real PX4
        decide which run it hands over ([`take`][multicosim.trace._session.TestTrace.take]). Its
        fingerprint is then not deterministic."""
        self.example = 0
        self._evaluation: tuple[Evaluated, Signals] | None = None
        self._lock = threading.Lock()

    def attach(
        self,
        simulation: object,
        *,
        types: Mapping[str, Any] | None = None,
        converters: Sequence[Converter] = (),
    ) -> Recorder | None:
        """Record ``simulation`` (unless ``record`` is off: then None).

        Scenario ``types``/``converters`` add to the test's own.
        """
        if not self.record:
            return None
        known = self._recorded(simulation)
        if known is not None:
            return known  # already recorded since it started (``record_started``)
        recorder = Recorder(
            types={**self.types, **(types or {})},
            converters=[*self.converters, *converters],
        )
        recorder.attach(simulation)
        with self._lock:
            self.recorders.append(recorder)
            self._sources[id(simulation)] = recorder
        return recorder

    def adopt(self, simulation: object) -> None:
        """Record ``simulation``, which just started (``record_started``).

        A scenario's simulation wraps a local one already recorded: its recording goes on
        as the scenario's (what was recorded stays), with the scenario's trace options,
        which are read when the scenario's simulation is complete (at
        [`save`][multicosim.trace._session.TestTrace.save]).
        """
        if self.record:
            self.attach(simulation)

    def _recorded(self, simulation: object) -> Recorder | None:
        """The recorder of ``simulation`` or of the simulation it wraps, if either has one.

        A wrapper's trace options (a scenario's) are the ones its recording is saved with.
        """
        with self._lock:
            found = self._sources.get(id(simulation))
            if found is not None:
                return found
            inner = getattr(simulation, "simulation", None)
            found = self._sources.get(id(inner)) if inner is not None else None
            if found is not None:
                self._sources[id(simulation)] = found
                self._wrapped[id(found)] = simulation
            return found

    def take(self, other: TestTrace) -> None:
        """Hold what ``other`` recorded instead of what this one did (a search's run).

        A falsification inside a test hands over the last violating run, so that the
        test's trace is that run's, as a failing test's is.
        """
        if not self.record:
            return
        other.detach()
        with self._lock:
            self.detach()
            self.recorders = list(other.recorders)
            self._sources = dict(other._sources)
            self._wrapped = dict(other._wrapped)
            self._evaluation = other._evaluation

    def begin_example(self) -> None:
        """A new Hypothesis example starts: drop the recordings of the previous one."""
        with self._lock:
            for recorder in self.recorders:
                recorder.detach()
            self.recorders = []
            self._sources = {}
            self._wrapped = {}
            self._evaluation = None
            self.example += 1

    def detach(self) -> None:
        """Stop recording every simulation (what was recorded stays); idempotent."""
        for recorder in self.recorders:
            recorder.detach()

    def note_evaluation(self, requirement: object, signals: Signals, evaluation: Evaluated) -> None:
        """Keep the latest requirement evaluation (its trajectory and robustness go in)."""
        if self.record:
            self._evaluation = (evaluation, signals)

    @property
    def evaluation(self) -> Evaluated | None:
        """The latest requirement evaluation noted, if any."""
        return self._evaluation[0] if self._evaluation is not None else None

    @property
    def deterministic(self) -> bool:
        """Whether runs of one seed record the same samples here (no real firmware flew)."""
        with self._lock:
            recorders = list(self.recorders)
            wrappers = [self._wrapped.get(id(r)) for r in recorders]
        # A scenario's own options say whether its firmware is real (they are applied to
        # its recording when it is saved; read them now).
        return not self.depends_on_firmware and all(
            (r.options if w is None else trace_options(w)).deterministic
            for r, w in zip(recorders, wrappers, strict=True)
        )

    def fingerprint(self) -> Fingerprint:
        """The hash of every sample the test's simulations routed (see
        [`fingerprint`][multicosim.trace._session.TestTrace.fingerprint])."""
        with self._lock:
            recorders = list(self.recorders)
        found = fingerprint(recorders)
        found.deterministic = self.deterministic
        return found

    def save(self, directory: str | Path, *, plot: bool = True, **metadata: object) -> list[Path]:
        """Write one MCAP trace per recorded simulation, and beside each its Foxglove layout
        (``.layout.json``), its MAVLink traffic (``.tlog``, where there is some) and a PNG plot.

        Returns the written paths (traces with their layouts and logs, then plots). Nothing is
        written when nothing was recorded. A failing plot (matplotlib missing, say) does not
        prevent the trace.
        """
        from ._plot import plot_trace

        directory = Path(directory)
        recorders = list(self.recorders)
        if not recorders and self._evaluation is not None:
            recorders = [Recorder(types=self.types, converters=self.converters)]
        written: list[Path] = []
        plots: list[Path] = []
        for index, recorder in enumerate(recorders):
            wrapper = self._wrapped.get(id(recorder))
            if wrapper is not None:
                recorder.use_options(wrapper)
            recorder.metadata.update(self.metadata)
            if self._evaluation is not None and index == len(recorders) - 1:
                evaluation, signals = self._evaluation
                recorder.add_signals(signals, TRAJECTORY_CHANNEL)
                recorder.add_evaluation(evaluation)
            name = "trace" if len(recorders) == 1 else f"trace-{index}"
            path = recorder.save(directory / f"{name}.mcap", **metadata)
            written.append(path)
            written.append(recorder.save_layout(directory / f"{name}.layout.json"))
            tlog = recorder.save_tlog(directory / f"{name}.tlog")
            if tlog is not None:
                written.append(tlog)
            if plot:
                try:
                    plots.append(plot_trace(path, directory / f"{name}.png"))
                except Exception as exc:  # a plot is a diagnosis aid: keep the trace anyway
                    log.warning("could not plot %s: %s", path, exc)
        return written + plots


def _record_started(simulation: object) -> None:
    current = _current.get()
    if current is not None and current.record_started:
        # A simulation without a simulated clock has nothing to record.
        with contextlib.suppress(MulticosimError):
            current.adopt(simulation)


add_start_observer(_record_started)


def active() -> TestTrace | None:
    """The trace of the test running now, if the plugin (or a search) activated one."""
    return _current.get()


@contextlib.contextmanager
def activate(test_trace: TestTrace) -> Iterator[TestTrace]:
    """Make ``test_trace`` the active one for the duration of the block (one test)."""
    token = _current.set(test_trace)
    try:
        yield test_trace
    finally:
        _current.reset(token)
        test_trace.detach()


def note_evaluation(requirement: object, signals: Signals, evaluation: Evaluated) -> None:
    """Called by Requirement.evaluate: note it in the active test's trace."""
    current = _current.get()
    if current is not None:
        current.note_evaluation(requirement, signals, evaluation)
