"""What a run's models are: its fidelity level, the one list of levels that every scenario,
search and option accepts (where components run is a placement:
[`multicosim.placement`][multicosim.placement])."""

from __future__ import annotations

from typing import Literal, TypeGuard

from .errors import ConfigurationError

__all__ = [
    "FIDELITIES",
    "FIRMWARE_FIDELITIES",
    "Fidelity",
    "FirmwareFidelity",
    "check_fidelity",
    "is_fidelity",
]

Fidelity = Literal["low", "medium", "high"]
# Lowest first: analytic models in-process, MuJoCo in processes, MuJoCo's finest settings.
FIDELITIES: tuple[Fidelity, ...] = ("low", "medium", "high")

FirmwareFidelity = Literal["medium", "high"]
# Real firmware (PX4, ArduPilot SITL) flies the MuJoCo world: it has no low fidelity.
FIRMWARE_FIDELITIES: tuple[FirmwareFidelity, ...] = ("medium", "high")


def is_fidelity(value: object) -> TypeGuard[Fidelity]:
    """Whether ``value`` names a fidelity level."""
    return value in FIDELITIES


def check_fidelity(value: object, field: str = "fidelity") -> Fidelity:
    """``value`` as a level; ConfigurationError naming ``field`` if it is none."""
    if not is_fidelity(value):
        raise ConfigurationError(field, value, f"one of {', '.join(map(repr, FIDELITIES))}")
    return value
