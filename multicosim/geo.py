"""Former home of :mod:`multicosim.core.geo`, kept so that user code keeps working."""

from .core.geo import *  # noqa: F403
from .core.geo import __all__ as __all__
