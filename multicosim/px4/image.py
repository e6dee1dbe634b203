"""The real-PX4 image: the runtime image with a PX4 SITL directory, built through the Docker
placement's API (``multicosim images build --px4-dir DIR``; on first use by the ``docker``
placement when only a binary is given)."""

from __future__ import annotations

import os
from collections.abc import Callable

from ..core.version import __version__

__all__ = ["IMAGE", "build_image"]

IMAGE = f"multicosim/px4-sitl:{__version__}"
"""The real-PX4 image's tag."""


def build_image(
    px4_dir: str | os.PathLike[str],
    *,
    tag: str = IMAGE,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> str:
    """Build the real-PX4 image from a PX4 SITL directory (``bin/px4`` and ``etc``); its tag.

    The image is the runtime image (``multicosim px4 launch`` prepares PX4's working
    directory inside it) with the directory's ``bin`` and ``etc`` copied to /opt/px4; no
    registry is contacted. Skipped when its inputs did not change, unless ``force``.
    """
    from ..docker import build_from_directory

    return build_from_directory(
        "px4",
        px4_dir,
        required=("bin/px4", "etc/init.d-posix/rcS"),
        parts=("bin", "etc"),
        what="a PX4 SITL directory (a px4_sitl_default build or bundle with bin/px4 and etc/)",
        tag=tag,
        force=force,
        progress=progress,
    )
