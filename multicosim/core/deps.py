"""Optional dependencies and lazy exports: heavy modules load on use, never on import.

``require`` imports an optional dependency or raises an error naming the extra to
install; ``lazy_exports`` gives a package the ``__getattr__`` / ``__dir__`` pair that
loads each exported name from its module the first time it is used (so that
``import multicosim`` imports neither pyzmq, MuJoCo, the Docker SDK nor mcap):

```python
__getattr__, __dir__ = lazy_exports(__name__, {"World": ".world"}, __all__)
```
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterable, Mapping
from types import ModuleType
from typing import Any

from .errors import DependencyMissingError

__all__ = ["lazy_exports", "require"]


def require(module: str, extra: str) -> ModuleType:
    """Import ``module`` or raise DependencyMissingError naming ``multicosim[extra]``."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        if exc.name is not None and module.split(".")[0] != exc.name.split(".")[0]:
            raise  # the module exists but one of its own imports failed: show that
        raise DependencyMissingError(module, extra) from exc


def lazy_exports(
    package: str, exports: Mapping[str, str], names: Iterable[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package``: each of ``exports`` (name -> module,
    relative to ``package``, or ``module:attribute`` where the module names it otherwise) is
    imported on first use and then kept in the package."""
    listed = sorted(names)

    def __getattr__(name: str) -> Any:
        target = exports.get(name)
        if target is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attribute = target.partition(":")
        value = getattr(importlib.import_module(module, package), attribute or name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return listed

    return __getattr__, __dir__
