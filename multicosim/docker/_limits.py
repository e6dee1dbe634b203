"""ContainerLimits: what a component's container may use, and as whom it runs.

Whatever the limits, every container is hardened the same way (no capabilities, no new
privileges, an init process); the limits add its user, memory and process caps.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from ..core.errors import ConfigurationError
from ..local.waits import memory_bytes

__all__ = ["NONROOT_USER", "ContainerLimits"]

NONROOT_USER = "10001:10001"
"""The user (uid:gid) component containers run as unless told otherwise: not root, and not
a user of the host (the runtime image names it ``multicosim``)."""

_MIN_MEMORY = 6 << 20  # the engine refuses less


@dataclasses.dataclass(frozen=True)
class ContainerLimits:
    """What a component's container may use, and as whom it runs.

    ``user`` runs its program (``"uid:gid"`` or a name; None: the image's own user, which is
    often root); ``memory`` caps its memory, swap included (bytes, or ``"512m"``, ``"2g"``);
    ``pids`` caps its processes and threads (a fork bomb stops there). Whatever the limits,
    every container drops all Linux capabilities, cannot gain privileges
    (``no-new-privileges``), runs an init process, carries the run's labels, and joins only
    its simulation's network (never the host's).
    """

    user: str | None = NONROOT_USER
    memory: int | str = "2g"
    pids: int = 512

    def __post_init__(self) -> None:
        if self.user is not None and (
            not isinstance(self.user, str) or not self.user or any(c.isspace() for c in self.user)
        ):
            raise ConfigurationError("user", self.user, "None, 'uid:gid' or a user name")
        if _memory_bytes(self.memory) is None:
            raise ConfigurationError(
                "memory", self.memory, "bytes (an integer >= 6 MiB) or a size like '512m', '2g'"
            )
        if isinstance(self.pids, bool) or not isinstance(self.pids, int) or self.pids < 16:
            raise ConfigurationError("pids", self.pids, "an integer >= 16")

    @property
    def memory_bytes(self) -> int:
        """``memory`` in bytes."""
        size = _memory_bytes(self.memory)
        assert size is not None  # checked on construction
        return size

    def host_config(self) -> dict[str, Any]:
        """The engine's HostConfig settings these limits (and the fixed hardening) make."""
        memory = self.memory_bytes
        return {
            "init": True,
            "cap_drop": ["ALL"],
            "security_opt": ["no-new-privileges:true"],
            "pids_limit": self.pids,
            "mem_limit": memory,
            "memswap_limit": memory,  # no swap beyond the memory limit
        }


def _memory_bytes(value: object) -> int | None:
    return memory_bytes(value, _MIN_MEMORY)


def _check_limits(limits: object) -> None:
    if not isinstance(limits, ContainerLimits):
        raise ConfigurationError("limits", limits, "a ContainerLimits")
