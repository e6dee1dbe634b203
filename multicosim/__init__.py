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
from ._fidelity import BACKENDS, FIDELITIES, Backend, Fidelity
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
    "ProcessFirmwareNode": "._local",
    "ProcessFirmwareComponent": "._local",
    "ThreadFirmwareComponent": "._local",
    "InProcessFirmwareComponent": "._local",
    "InProcessFirmwareNode": "._local",
    "SelfContainedSimulation": "._local",
    "SelfContainedSimulator": "._local",
    "LocalEnvironment": "._local",
    "InProcessComponent": "._local",
    "InProcessNode": "._local",
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
    "ContainerFirmwareComponent": ".docker",
    "FirmwareComponent": ".docker",  # the paper's name for ContainerFirmwareComponent
    "Requirement": ".requirements",
}

__all__ = [
    "BACKENDS",
    "FIDELITIES",
    "AttachedComponent",
    "Backend",
    "CampaignInterrupted",
    "CommunicationNode",
    "Component",
    "ComponentCheckError",
    "ConfigurationError",
    "ContainerComponent",
    "ContainerFirmwareComponent",
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
    "ProcessComponent",
    "ProcessFirmwareComponent",
    "ProcessFirmwareNode",
    "ProcessNode",
    "ProcessSimulation",
    "ProcessSimulator",
    "RemoteError",
    "Requirement",
    "RequirementViolation",
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
    from ._local import (
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
        ScenarioSimulation,
        SelfContainedSimulation,
        SelfContainedSimulator,
        ThreadFirmwareComponent,
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
        ContainerFirmwareComponent,
        ContainerNode,
        ContainerSimulation,
        ContainerSimulator,
        FirmwareComponent,
    )
    from .requirements import Requirement


# Former names, kept as deprecated aliases: old name -> new name.
_DEPRECATED = {
    "ParticipantComponent": "InProcessComponent",
    "ParticipantNode": "InProcessNode",
    "FirmwareProcessComponent": "ProcessFirmwareComponent",
    "FirmwareThreadComponent": "ThreadFirmwareComponent",
    "FirmwareNode": "ProcessFirmwareNode",
    "InProcessSimulator": "SelfContainedSimulator",
    "InProcessSimulation": "SelfContainedSimulation",
}


def __getattr__(name: str) -> Any:
    if name in _DEPRECATED:
        from ._deps import renamed

        return __getattr__(renamed(__name__, name, _DEPRECATED))
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'multicosim' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
