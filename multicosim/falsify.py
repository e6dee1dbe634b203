"""Former home of :mod:`multicosim.search.falsify`, kept so that user code keeps working."""

from .search.falsify import *  # noqa: F403
from .search.falsify import __all__ as __all__
