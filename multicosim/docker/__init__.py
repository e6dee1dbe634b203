"""The Docker backend: the paper's container classes on the Docker SDK.

Needs the ``docker`` extra (``pip install 'multicosim[docker]'``) and a running engine.
The SDK is imported when a class is first used, so that component programs running inside
an image (which import ``multicosim.docker._selftest``, for example) do not need it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports

_LAZY = {
    "AttachedComponent": "._attached",
    "AttachedNode": "._attached",
    "ContainerComponent": "._component",
    "ContainerEnvironment": ".environment",
    "ContainerFirmwareNode": "._firmware",
    "ContainerLimits": "._limits",
    "ContainerNode": ".node",
    "ContainerFirmwareComponent": "._firmware",
    "FirmwareComponent": "._firmware:ContainerFirmwareComponent",  # the paper's name
    "ContainerSimulation": "._simulator",
    "ContainerSimulator": "._simulator",
    "EngineUnavailableError": "..core.errors",
    "ImageMissingError": "..core.errors",
    "BASE_IMAGE": "._images",
    "RUNTIME_IMAGE": "._images",
    "build_derived": "._images",
    "build_from_directory": "._images",
    "build_images": "._images:build",
    "Docker": ".placement",
    "SweepReport": "._sweep",
    "engine_available": "._sweep",
    "sweep": "._sweep",
}
__all__ = [
    "BASE_IMAGE",
    "RUNTIME_IMAGE",
    "AttachedComponent",
    "AttachedNode",
    "ContainerComponent",
    "ContainerEnvironment",
    "ContainerFirmwareComponent",
    "ContainerFirmwareNode",
    "ContainerLimits",
    "ContainerNode",
    "ContainerSimulation",
    "ContainerSimulator",
    "Docker",
    "EngineUnavailableError",
    "FirmwareComponent",
    "ImageMissingError",
    "SweepReport",
    "build_derived",
    "build_from_directory",
    "build_images",
    "engine_available",
    "sweep",
]

if TYPE_CHECKING:
    from ..core.errors import EngineUnavailableError as EngineUnavailableError
    from ..core.errors import ImageMissingError as ImageMissingError
    from ._attached import AttachedComponent as AttachedComponent
    from ._attached import AttachedNode as AttachedNode
    from ._component import ContainerComponent as ContainerComponent
    from ._firmware import ContainerFirmwareComponent as ContainerFirmwareComponent
    from ._firmware import ContainerFirmwareComponent as FirmwareComponent
    from ._firmware import ContainerFirmwareNode as ContainerFirmwareNode
    from ._images import BASE_IMAGE as BASE_IMAGE
    from ._images import RUNTIME_IMAGE as RUNTIME_IMAGE
    from ._images import build as build_images
    from ._images import build_derived as build_derived
    from ._images import build_from_directory as build_from_directory
    from ._limits import ContainerLimits as ContainerLimits
    from ._simulator import ContainerSimulation as ContainerSimulation
    from ._simulator import ContainerSimulator as ContainerSimulator
    from ._sweep import SweepReport as SweepReport
    from ._sweep import engine_available as engine_available
    from ._sweep import sweep as sweep
    from .environment import ContainerEnvironment as ContainerEnvironment
    from .node import ContainerNode as ContainerNode
    from .placement import Docker as Docker


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
