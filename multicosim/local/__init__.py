"""Local execution: components in-process or as local processes, in lockstep.

``ProcessSimulator`` is the embedded default backend (no Docker needed). Its environment
([`LocalEnvironment`][multicosim.local.LocalEnvironment]) holds the simulated clock and, once a
process needs it, the coordinator socket through which process components are stepped.

The backend lives in modules of one concern each; this module gathers their public names:

* ``waits``: timeouts and crash reports; ``rundirs``: run directories and the sweep;
* ``coordinator``: the lockstep socket; ``environment``: what components are given;
* ``processes``: local processes; ``firmware``: firmware nodes over ZeroMQ;
* ``inprocess``: in-process components; ``simulators`` and ``simulation``: simulators and
  the running set (the scenarios' base is ``multicosim.placement.scenario``);
* ``check``: ``check_component``, the conformance check of a component of one's own;
* ``load``: ``CpuLoad``, busy processes for tests and soaks under load.
"""

from __future__ import annotations

from .coordinator import Coordinator
from .environment import LocalEnvironment
from .firmware import (
    ProcessFirmwareComponent,
    ProcessFirmwareNode,
    ThreadFirmwareComponent,
    check_types,
)
from .inprocess import (
    InProcessComponent,
    InProcessFirmwareComponent,
    InProcessFirmwareNode,
    InProcessNode,
)
from .load import CpuLoad
from .processes import (
    ProcessComponent,
    ProcessHandle,
    ProcessNode,
    check_port,
    default_name,
    split_command,
)
from .rundirs import remove_tree, runs_directory, sweep_stale_runs
from .simulators import (
    LocalSimulatorBase,
    ProcessSimulation,
    ProcessSimulator,
    SelfContainedSimulation,
    SelfContainedSimulator,
    config_json,
    participant_command,
    required_images,
)
from .waits import (
    DEFAULT_SEND_TIMEOUT,
    DEFAULT_START_TIMEOUT,
    DEFAULT_STEP_TIMEOUT,
    Watch,
    check_timeout,
    crashed,
    ending,
    mark_reported,
    stalled,
)

__all__ = [
    "DEFAULT_SEND_TIMEOUT",
    "DEFAULT_START_TIMEOUT",
    "DEFAULT_STEP_TIMEOUT",
    "Coordinator",
    "CpuLoad",
    "InProcessComponent",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "InProcessNode",
    "LocalEnvironment",
    "LocalSimulatorBase",
    "ProcessComponent",
    "ProcessFirmwareComponent",
    "ProcessFirmwareNode",
    "ProcessHandle",
    "ProcessNode",
    "ProcessSimulation",
    "ProcessSimulator",
    "SelfContainedSimulation",
    "SelfContainedSimulator",
    "ThreadFirmwareComponent",
    "Watch",
    "config_json",
    "crashed",
    "default_name",
    "ending",
    "mark_reported",
    "participant_command",
    "required_images",
    "runs_directory",
    "stalled",
    "sweep_stale_runs",
]

# The names other modules imported from here before the backend was split.
_check_positive = check_timeout
_check_types = check_types
_check_port = check_port
_split_command = split_command
_remove_tree = remove_tree
