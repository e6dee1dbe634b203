"""The FMU participant: an FMU stepped on the simulated clock, wherever it runs.

At each step (every ``period``, at FMI time ``start_time + n * period``) it sets the inputs
that arrived on its topics, publishes its record and its mapped outputs for that instant,
then advances the FMU to the next communication point (``doStep``, or the solver for model
exchange). Communication points are computed as fmpy.simulate_fmu computes them, so an FMU
run alone gives FMPy's result.

The same program runs in-process, as a process or in a container
(``multicosim participant multicosim.fmi:participant --config JSON``).
"""

from __future__ import annotations

import atexit
import logging
import math
import shutil
import tempfile
from pathlib import Path
from typing import IO, Any

from ..runtime.context import StepContext, Subscription
from .config import FMUConfig, Plan, plan
from .errors import FMUError
from .instance import STATUS, Instance
from .messages import LogLine

__all__ = ["PROGRAM", "FMUParticipant", "participant"]

PROGRAM = "multicosim.fmi:participant"
_LOG_TAIL = 20

log = logging.getLogger(__name__)


class FMUParticipant:
    """An FMU as a participant (``period``, ``setup``, ``step``, ``close``).

    ``keep_log`` and ``keep_history`` keep what it publishes in
    [`log_lines`][multicosim.fmi.participant.FMUParticipant.log_lines] and
    [`history`][multicosim.fmi.participant.FMUParticipant.history] (its records) too, for a node in
    the same process.
    """

    def __init__(
        self,
        config: FMUConfig,
        resolved: Plan | None = None,
        *,
        keep_log: bool = False,
        keep_history: bool = False,
    ) -> None:
        self.config = config
        self.plan = resolved or plan(config)
        self.period = config.period
        # What it publishes may stay here too, for a node in this process to read without a
        # scheduler tap: its log lines, and its records.
        self.log_lines: list[LogLine] | None = [] if keep_log else None
        self.history: list[Any] | None = [] if keep_history else None
        # What every step reads, looked up once.
        self._times = (config.start_time, config.period, config.stop_time)
        self._topic = self.plan.topic
        self._record_type = self.plan.record_type
        self._outputs = self.plan.outputs
        self.instance: Instance | None = None
        self.steps = 0
        self.done = False
        self._ending = False
        self._lines: list[tuple[str, str, str]] = []
        self._tail: list[str] = []
        self._reason = ""  # the FMU's last Error or Fatal message: why a call failed
        self._log: IO[str] | None = None
        self._unzipdir: str | None = None
        self._own_dir: str | None = None
        self._inputs: list[tuple[Subscription[Any], Any]] = []

    # -- set-up ---------------------------------------------------------------------------

    def setup(self, ctx: StepContext) -> None:
        """Extract, instantiate and initialize the FMU; subscribe to its input topics."""
        config, resolved = self.config, self.plan
        try:
            self._unzipdir = self._extract()
            instance = Instance(
                resolved.model,
                interface=config.interface,
                unzipdir=self._unzipdir,
                name=config.name,
                debug_logging=config.debug_logging,
                on_log=self._on_log,
            )
            self.instance = instance
            instance.initialize(
                resolved.values,
                start_time=config.start_time,
                stop_time=config.stop_time,
                tolerance=config.tolerance
                if config.tolerance is not None
                else resolved.model.tolerance,
                solver=config.solver,
            )
        except FMUError as exc:
            self._flush(ctx)
            exc.add_log(self._tail, self._reason)
            self.close()
            raise
        except BaseException:
            self.close()
            raise
        self._read = instance.reader(resolved.recorded)
        self._inputs = [(ctx.subscribe(t, tp), instance.setter(v)) for t, v, tp in resolved.inputs]
        self._flush(ctx)

    def _extract(self) -> str:
        path = Path(self.config.path)
        if path.is_dir():
            return str(path)
        from fmpy import extract

        if self.config.workdir is not None:
            target = Path(self.config.workdir)
            target.mkdir(parents=True, exist_ok=True)
            return str(extract(str(path), str(target)))
        self._own_dir = tempfile.mkdtemp(prefix=f"mcs-fmu-{self.config.name}-")
        return str(extract(str(path), self._own_dir))

    # -- stepping -------------------------------------------------------------------------

    def step(self, ctx: StepContext) -> None:
        """Apply new inputs, publish this instant's values, advance to the next point."""
        if self.done:
            return
        instance = self.instance
        assert instance is not None, "setup() was not called"
        n = self.steps
        start, period, stop = self._times
        # As fmpy.simulate_fmu: the n-th point is start + n * period, computed afresh.
        time = start + n * period if n else start
        until = start + (n + 1) * period
        finished = self._ending
        if stop is not None:
            if time > stop:  # the last step was cut short at the stop time
                time = stop
            finished = finished or time >= stop or math.isclose(time, stop)
            if until > stop and not math.isclose(until, stop):
                until = stop
        if self._ending:  # the FMU ended the run, at its last successful time
            time = instance.time
        # Read before any FMI call: a message that does not decode is the publisher's
        # fault (a TransportError naming the topic), not the FMU's.
        arrived = [(set_value, sub.messages) for sub, set_value in self._inputs]
        try:
            for set_value, messages in arrived:
                if messages:
                    set_value(messages[-1])
            values = self._read()
            if not finished:
                instance.advance(time, until)
        except Exception as exc:  # FMPy's FMICallException, or the solver's
            error = instance.failure(exc, "step", time, ctx.time)
            self._failed(ctx, error)
            raise error from exc
        record = self._record_type(time, *values)
        ctx.publish(self._topic, record)
        if self.history is not None:
            self.history.append(record)
        for index, topic in self._outputs:
            ctx.publish(topic, values[index])
        if finished:
            self._finish(ctx)
            return
        self.steps = n + 1
        if instance.terminated:
            self._on_log(1, "multicosim", f"the FMU ended its run at t={instance.time:.9g} s")
            self._ending = True
        if self._lines:
            self._flush(ctx)

    def _failed(self, ctx: StepContext, error: FMUError) -> None:
        self.done = True
        self._flush(ctx)
        error.add_log(self._tail, self._reason)

    def _finish(self, ctx: StepContext) -> None:
        # The run is over (stop time, or the FMU asked to end): nothing is published after.
        self.done = True
        self._flush(ctx)

    # -- the FMU's log --------------------------------------------------------------------

    def _on_log(self, status: int, category: str, message: str) -> None:
        # Called from inside FMI calls (from C): must not raise. Written at once, so that the
        # line is in the component's log even if the FMU's next instruction kills the process.
        try:
            label = STATUS[status] if 0 <= status < len(STATUS) else str(status)
            text = f"[{label}] {category}: {message}" if category else f"[{label}] {message}"
            self._tail = [*self._tail[-(_LOG_TAIL - 1) :], text]
            self._lines.append((label, category, message))
            if label in ("Error", "Fatal"):
                self._reason = message
            time = self.instance.time if self.instance is not None else self.config.start_time
            log_file = self.config.log_file
            if log_file is not None:
                if self._log is None:  # opened with the first line: no empty logs
                    self._log = open(log_file, "a", encoding="utf-8")  # noqa: SIM115 - close()
                self._log.write(f"t={time:.9g} {self.config.name} {text}\n")
                self._log.flush()
            else:
                level = logging.INFO if status == 0 else logging.WARNING
                log.log(level if status <= 2 else logging.ERROR, "%s %s", self.config.name, text)
        except Exception:  # pragma: no cover - nothing may propagate into C
            pass

    def _flush(self, ctx: StepContext) -> None:
        """Publish the log lines kept since the last step on the log topic."""
        lines, self._lines = self._lines, []
        for label, category, message in lines:
            line = LogLine(label, category, message)
            ctx.publish(self.plan.log_topic, line)
            if self.log_lines is not None:
                self.log_lines.append(line)

    # -- the end --------------------------------------------------------------------------

    def close(self) -> None:
        """Terminate and free the FMU, remove what was extracted; idempotent."""
        instance, self.instance = self.instance, None
        try:
            if instance is not None:
                instance.close()
        finally:
            if self._own_dir is not None:
                shutil.rmtree(self._own_dir, ignore_errors=True)
                self._own_dir = None
            if self._log is not None:
                self._log.close()
                self._log = None


def participant(config: FMUConfig) -> FMUParticipant:
    """The FMU participant program (``multicosim participant multicosim.fmi:participant``).

    In its own process the instance is freed, and its temporary directory removed, at exit.
    """
    made = FMUParticipant(config)
    atexit.register(made.close)
    return made
