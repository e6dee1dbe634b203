"""multicosim: compose co-simulations of CPS components and test them with pytest.

``import multicosim as mcs`` gives the paper's interfaces (Node, CommunicationNode,
Component, Simulator, Simulation, NodeId), typed messages, the component-side API
(``@mcs.firmware``, participants, topics on a simulated clock), the local backend and the
paper's container classes (``mcs.ContainerSimulator``, ``mcs.FirmwareComponent``, ...).
Heavy backends live in submodules (``multicosim.docker``, ``multicosim.physics``, ...) and
are imported only when used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .core.deps import lazy_exports
from .core.errors import (
    ConfigurationError,
    DependencyMissingError,
    EngineUnavailableError,
    FormulaError,
    ImageMissingError,
    MessageTypeError,
    MulticosimError,
    NodeCrashedError,
    NodeError,
    NodeStartError,
    NodeTimeoutError,
    PhysicsDivergedError,
    PlacementUnavailableError,
    RemoteError,
    SimulationStopped,
    TraceError,
    TransportError,
)
from .core.fidelity import FIDELITIES, Fidelity
from .core.interfaces import CommunicationNode, Component, Node, NodeId, Simulation, Simulator
from .core.messages import Message
from .core.version import __version__

# The local backend and runtime import pyzmq; they load on first use so that
# ``import multicosim`` stays light (and never imports docker, mujoco or mcap).
_LAZY = {
    **dict.fromkeys(
        (
            "Firmware",
            "FirmwareContext",
            "Participant",
            "StepContext",
            "Subscription",
            "firmware",
            "run_participant",
            "serve",
        ),
        ".runtime",
    ),
    **dict.fromkeys(
        (
            "ProcessFirmwareNode",
            "ProcessFirmwareComponent",
            "ThreadFirmwareComponent",
            "InProcessFirmwareComponent",
            "InProcessFirmwareNode",
            "SelfContainedSimulation",
            "SelfContainedSimulator",
            "LocalEnvironment",
            "InProcessComponent",
            "InProcessNode",
            "ProcessComponent",
            "ProcessNode",
            "ProcessSimulation",
            "ProcessSimulator",
        ),
        ".local",
    ),
    **dict.fromkeys(("Placement", "Scenario", "ScenarioSimulation"), ".placement"),
    # The paper's container classes, where its listings take them from (``mcs.``); the
    # Docker SDK loads when one is first used.
    **dict.fromkeys(
        (
            "AttachedComponent",
            "AttachedNode",
            "ContainerComponent",
            "ContainerFirmwareNode",
            "ContainerNode",
            "ContainerSimulation",
            "ContainerSimulator",
            "FirmwareComponent",
        ),
        ".docker",
    ),
    # Errors that carry a payload live beside it.
    "ComponentCheckError": ".local.check",
    "CampaignInterrupted": ".search.campaign",
    "RequirementViolation": ".search.requirements",
    "Requirement": ".search.requirements",
}

__all__ = [
    "FIDELITIES",
    "AttachedComponent",
    "AttachedNode",
    "CampaignInterrupted",
    "CommunicationNode",
    "Component",
    "ComponentCheckError",
    "ConfigurationError",
    "ContainerComponent",
    "ContainerFirmwareNode",
    "ContainerNode",
    "ContainerSimulation",
    "ContainerSimulator",
    "DependencyMissingError",
    "EngineUnavailableError",
    "Fidelity",
    "Firmware",
    "FirmwareComponent",
    "FirmwareContext",
    "FormulaError",
    "ImageMissingError",
    "InProcessComponent",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "InProcessNode",
    "LocalEnvironment",
    "Message",
    "MessageTypeError",
    "MulticosimError",
    "Node",
    "NodeCrashedError",
    "NodeError",
    "NodeId",
    "NodeStartError",
    "NodeTimeoutError",
    "Participant",
    "PhysicsDivergedError",
    "Placement",
    "PlacementUnavailableError",
    "ProcessComponent",
    "ProcessFirmwareComponent",
    "ProcessFirmwareNode",
    "ProcessNode",
    "ProcessSimulation",
    "ProcessSimulator",
    "RemoteError",
    "Requirement",
    "RequirementViolation",
    "Scenario",
    "ScenarioSimulation",
    "SelfContainedSimulation",
    "SelfContainedSimulator",
    "Simulation",
    "SimulationStopped",
    "Simulator",
    "StepContext",
    "Subscription",
    "ThreadFirmwareComponent",
    "TraceError",
    "TransportError",
    "__version__",
    "firmware",
    "run_participant",
    "serve",
]

if TYPE_CHECKING:
    from .docker import (
        AttachedComponent,
        AttachedNode,
        ContainerComponent,
        ContainerFirmwareNode,
        ContainerNode,
        ContainerSimulation,
        ContainerSimulator,
        FirmwareComponent,
    )
    from .local import (
        InProcessComponent,
        InProcessFirmwareComponent,
        InProcessFirmwareNode,
        InProcessNode,
        LocalEnvironment,
        ProcessComponent,
        ProcessFirmwareComponent,
        ProcessFirmwareNode,
        ProcessNode,
        ProcessSimulation,
        ProcessSimulator,
        SelfContainedSimulation,
        SelfContainedSimulator,
        ThreadFirmwareComponent,
    )
    from .local.check import ComponentCheckError
    from .placement import Placement, Scenario, ScenarioSimulation
    from .runtime import (
        Firmware,
        FirmwareContext,
        Participant,
        StepContext,
        Subscription,
        firmware,
        run_participant,
        serve,
    )
    from .search.campaign import CampaignInterrupted
    from .search.requirements import Requirement, RequirementViolation

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
