"""Former home of :mod:`multicosim.search.campaign`, kept so that user code keeps working."""

from .search.campaign import *  # noqa: F403
from .search.campaign import __all__ as __all__
