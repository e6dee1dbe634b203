"""Former home of :mod:`multicosim.search.strategies`, kept so that user code keeps working."""

from .search.strategies import *  # noqa: F403
from .search.strategies import __all__ as __all__
