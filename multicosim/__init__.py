"""multicosim: compose co-simulations of CPS components and test them with pytest.

``import multicosim as mcs`` gives the paper's interfaces (Node, CommunicationNode,
Component, Simulator, Simulation, NodeId), typed messages, the component-side API
(``@mcs.firmware``, participants, topics on a simulated clock) and the local backend.
Heavy backends live in submodules (``multicosim.docker``, ``multicosim.mujoco``, ...) and
are imported only when used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._errors import (
    CampaignInterrupted,
    ComponentCheckError,
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
    RemoteError,
    RequirementViolation,
    SimulationStopped,
    TraceError,
    TransportError,
)
from ._fidelity import FIDELITIES, Fidelity
from ._interfaces import CommunicationNode, Component, Node, NodeId, Simulation, Simulator
from ._messages import Message

__version__ = "0.1.0"

# The local backend and runtime import pyzmq; they load on first use so that
# ``import multicosim`` stays light (and never imports docker, mujoco or mcap).
_LAZY = {
    "Firmware": "._runtime",
    "FirmwareContext": "._runtime",
    "Participant": "._runtime",
    "StepContext": "._runtime",
    "Subscription": "._runtime",
    "firmware": "._runtime",
    "run_participant": "._runtime",
    "serve": "._runtime",
    "FirmwareNode": "._local",
    "FirmwareProcessComponent": "._local",
    "FirmwareThreadComponent": "._local",
    "InProcessFirmwareComponent": "._local",
    "InProcessFirmwareNode": "._local",
    "InProcessSimulation": "._local",
    "InProcessSimulator": "._local",
    "LocalEnvironment": "._local",
    "ParticipantComponent": "._local",
    "ParticipantNode": "._local",
    "ProcessComponent": "._local",
    "ProcessNode": "._local",
    "ProcessSimulation": "._local",
    "ProcessSimulator": "._local",
    "ScenarioSimulation": "._local",
    # The paper's container classes; the Docker SDK loads only when one is used.
    "AttachedComponent": ".docker",
    "ContainerComponent": ".docker",
    "ContainerNode": ".docker",
    "ContainerSimulation": ".docker",
    "ContainerSimulator": ".docker",
    "FirmwareComponent": ".docker",
    "Requirement": ".requirements",
}

__all__ = [
    "FIDELITIES",
    "AttachedComponent",
    "CampaignInterrupted",
    "CommunicationNode",
    "Component",
    "ComponentCheckError",
    "ConfigurationError",
    "ContainerComponent",
    "ContainerNode",
    "ContainerSimulation",
    "ContainerSimulator",
    "DependencyMissingError",
    "EngineUnavailableError",
    "Fidelity",
    "Firmware",
    "FirmwareComponent",
    "FirmwareContext",
    "FirmwareNode",
    "FirmwareProcessComponent",
    "FirmwareThreadComponent",
    "FormulaError",
    "ImageMissingError",
    "InProcessFirmwareComponent",
    "InProcessFirmwareNode",
    "InProcessSimulation",
    "InProcessSimulator",
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
    "ParticipantComponent",
    "ParticipantNode",
    "PhysicsDivergedError",
    "ProcessComponent",
    "ProcessNode",
    "ProcessSimulation",
    "ProcessSimulator",
    "RemoteError",
    "Requirement",
    "RequirementViolation",
    "ScenarioSimulation",
    "Simulation",
    "SimulationStopped",
    "Simulator",
    "StepContext",
    "Subscription",
    "TraceError",
    "TransportError",
    "__version__",
    "firmware",
    "run_participant",
    "serve",
]

if TYPE_CHECKING:
    from ._local import (
        FirmwareNode,
        FirmwareProcessComponent,
        FirmwareThreadComponent,
        InProcessFirmwareComponent,
        InProcessFirmwareNode,
        InProcessSimulation,
        InProcessSimulator,
        LocalEnvironment,
        ParticipantComponent,
        ParticipantNode,
        ProcessComponent,
        ProcessNode,
        ProcessSimulation,
        ProcessSimulator,
        ScenarioSimulation,
    )
    from ._runtime import (
        Firmware,
        FirmwareContext,
        Participant,
        StepContext,
        Subscription,
        firmware,
        run_participant,
        serve,
    )
    from .docker import (
        AttachedComponent,
        ContainerComponent,
        ContainerNode,
        ContainerSimulation,
        ContainerSimulator,
        FirmwareComponent,
    )
    from .requirements import Requirement


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'multicosim' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
