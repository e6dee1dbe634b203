"""Former home of :mod:`multicosim.physics`, kept so that user code keeps working."""

from typing import Any

from . import physics as _physics

__all__ = list(_physics.__all__)


def __getattr__(name: str) -> Any:
    return getattr(_physics, name)
