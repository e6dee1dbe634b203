"""Writing files whole or not at all.

A file written in place and interrupted (a full disk, a killed process) is left truncated,
and a truncated trace or log passes for a real one until someone reads it. ``replacing``
writes a temporary file beside the target and renames it over the target once complete;
on any failure the temporary file is removed and the target is left as it was. Used for the
artifacts of failing tests: traces, layouts, MAVLink logs, plots and copied logs.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from collections.abc import Iterator
from pathlib import Path

__all__ = ["replacing"]


@contextlib.contextmanager
def replacing(path: Path) -> Iterator[Path]:
    """Yield a temporary path to write; on success it becomes ``path`` (an atomic rename).

    The temporary file (``.NAME.RANDOM.part`` in the same directory, so the rename stays on
    one file system) is removed if the block raises. Parent directories are created.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{secrets.token_hex(4)}.part")
    try:
        yield temporary
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            temporary.unlink()
        raise
