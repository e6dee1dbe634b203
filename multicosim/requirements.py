"""Former home of :mod:`multicosim.search.requirements`, kept so that user code keeps working."""

from .search.requirements import *  # noqa: F403
from .search.requirements import __all__ as __all__
