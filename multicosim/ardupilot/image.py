"""The ArduPilot image: the runtime image with an ArduPilot SITL directory, built through the
Docker placement's API (``multicosim images build --ardupilot-dir DIR``; on first use by the
``docker`` placement when only a directory is given)."""

from __future__ import annotations

import os
from collections.abc import Callable

from ..core.version import __version__

__all__ = ["IMAGE", "build_image"]

IMAGE = f"multicosim/ardupilot-sitl:{__version__}"
"""The ArduPilot image's tag."""


def build_image(
    ardupilot_dir: str | os.PathLike[str],
    *,
    tag: str = IMAGE,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> str:
    """Build the ArduPilot image from an ArduPilot SITL directory; its tag.

    The directory holds ``bin/arducopter``, ``bin/ardurover`` and ``params/`` (ArduPilot's
    default parameter files); the image is the runtime image (``multicosim ardupilot
    launch`` writes the run's parameters and starts ArduPilot) with them in /opt/ardupilot.
    No registry is contacted. Skipped when its inputs did not change, unless ``force``.
    """
    from ..docker import build_from_directory

    return build_from_directory(
        "ardupilot",
        ardupilot_dir,
        required=("bin/arducopter", "bin/ardurover", "params/copter.parm", "params/rover.parm"),
        parts=("bin", "params"),
        what="an ArduPilot SITL directory (bin/arducopter, bin/ardurover, params/)",
        tag=tag,
        force=force,
        progress=progress,
    )
