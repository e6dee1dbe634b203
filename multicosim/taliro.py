"""Former home of :mod:`multicosim.search.taliro`, kept so that user code keeps working."""

from .search.taliro import *  # noqa: F403
from .search.taliro import __all__ as __all__
