"""Record every topic of a simulation into an MCAP file that Foxglove opens.

```python
from multicosim.trace import Recorder, read_trace

with Recorder().attach(simulation) as recorder:
    trajectory = simulation.controller.send(mission)
recorder.add_trajectory(trajectory)
recorder.save("run.mcap", seed=0, fidelity="low")
trace = read_trace("run.mcap")
```

Recording is cheap by design: the scheduler's tap only appends each routed message to a list;
conversion to JSON and writing happen in [`Recorder.save`][multicosim.trace.Recorder.save],
typically only for a failing test. Channels use JSON schemas (``jsonschema`` + ``json``; draft
2020-12, declared), generated from the message type when it is known: the in-process publisher's
object, or the ``types`` mapping (topic -> type) for messages that crossed a process boundary; other
topics get a permissive schema. Converters ([`location_fix`][multicosim.trace.location_fix],
[`pose_in_frame`][multicosim.trace.pose_in_frame], ...) add Foxglove well-known channels, whose
schemas are Foxglove's published ones. Beside a trace, [`TestTrace`][multicosim.trace.TestTrace]
saves a Foxglove layout (``.layout.json``), the MAVLink traffic (``.tlog``) where there is some, and
a PNG plot (``multicosim plot`` redraws it).

Log times are simulated time (nanoseconds from the start of the simulation), so the same seed
gives a byte-identical trace. [`fingerprint`][multicosim.trace.fingerprint] hashes what a run
routed; two runs of a seed that differ are located at their first differing sample (``--mcs-repeat``
uses it).

Modules: ``_schemas`` (schemas), ``_convert`` (converters, TraceOptions), ``_recorder``,
``_mcap`` (writing and reading MCAP), ``_fingerprint`` (a run's hash), ``_tlog``,
``_layout``, ``_session`` (the active TestTrace), ``_hypothesis`` (Hypothesis's failing
example), ``_plot``, ``_cli``.
"""

from __future__ import annotations

from ..core.clock import find_scheduler
from ._cli import plot_command
from ._convert import (
    ATTACK_CHANNEL,
    ENCOUNTER_CHANNEL,
    LOCATION_CHANNEL,
    OBSTACLES_CHANNEL,
    PATH_CHANNEL,
    PLAN_CHANNEL,
    POSE_CHANNEL,
    ROBUSTNESS_CHANNEL,
    SCENE_CHANNEL,
    TRAJECTORY_CHANNEL,
    Converted,
    Converter,
    TraceOptions,
    fix_message,
    local_path,
    location_fix,
    merge_options,
    pose,
    pose_in_frame,
    pose_message,
    scene_entity,
    trace_options,
)
from ._fingerprint import Difference, Fingerprint, fingerprint
from ._hypothesis import falsifying_example
from ._layout import layout, message_path
from ._mcap import METADATA_NAME, ChannelInfo, TraceData, TraceMessage, package_versions, read_trace
from ._plot import plot_trace
from ._recorder import Recorder
from ._schemas import (
    DIALECT,
    GEOJSON,
    LOCATION_FIX,
    LOG,
    OBSTACLES,
    PATH_POINT,
    PLAN,
    POSE_IN_FRAME,
    SCENE_UPDATE,
    Schema,
    foxglove_schema,
    object_schema,
    schema_for,
    stamp,
)
from ._session import TestTrace, activate, active, note_evaluation
from ._tlog import write_tlog

__all__ = [
    "ATTACK_CHANNEL",
    "DIALECT",
    "ENCOUNTER_CHANNEL",
    "GEOJSON",
    "LOCATION_CHANNEL",
    "LOCATION_FIX",
    "LOG",
    "METADATA_NAME",
    "OBSTACLES",
    "OBSTACLES_CHANNEL",
    "PATH_CHANNEL",
    "PATH_POINT",
    "PLAN",
    "PLAN_CHANNEL",
    "POSE_CHANNEL",
    "POSE_IN_FRAME",
    "ROBUSTNESS_CHANNEL",
    "SCENE_CHANNEL",
    "SCENE_UPDATE",
    "TRAJECTORY_CHANNEL",
    "ChannelInfo",
    "Converted",
    "Converter",
    "Difference",
    "Fingerprint",
    "Recorder",
    "Schema",
    "TestTrace",
    "TraceData",
    "TraceMessage",
    "TraceOptions",
    "activate",
    "active",
    "falsifying_example",
    "find_scheduler",
    "fingerprint",
    "fix_message",
    "foxglove_schema",
    "layout",
    "local_path",
    "location_fix",
    "merge_options",
    "message_path",
    "note_evaluation",
    "object_schema",
    "package_versions",
    "plot_command",
    "plot_trace",
    "pose",
    "pose_in_frame",
    "pose_message",
    "read_trace",
    "scene_entity",
    "schema_for",
    "stamp",
    "trace_options",
    "write_tlog",
]
