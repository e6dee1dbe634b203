"""Optional dependencies: import them on use, with an error naming the extra to install."""

from __future__ import annotations

import importlib
from types import ModuleType

from ._errors import DependencyMissingError

__all__ = ["renamed", "require"]


def renamed(module: str, old: str, renames: dict[str, str]) -> str:
    """The new name of ``module.old`` (a deprecated alias in ``renames``), with a warning."""
    import warnings

    new = renames[old]
    warnings.warn(
        f"{module}.{old} is deprecated: use {module}.{new}", DeprecationWarning, stacklevel=3
    )
    return new


def require(module: str, extra: str) -> ModuleType:
    """Import ``module`` or raise DependencyMissingError naming ``multicosim[extra]``."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        if exc.name is not None and module.split(".")[0] != exc.name.split(".")[0]:
            raise  # the module exists but one of its own imports failed: show that
        raise DependencyMissingError(module, extra) from exc
