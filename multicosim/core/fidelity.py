"""What a run is: its fidelity level and its backend, the one list of each that every
scenario, search and option accepts."""

from __future__ import annotations

from typing import Literal, TypeGuard

from .errors import ConfigurationError

__all__ = [
    "BACKENDS",
    "FIDELITIES",
    "FIRMWARE_FIDELITIES",
    "Backend",
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


Backend = Literal["process", "docker"]
# Where components run: in this process and local processes, or in Docker containers.
BACKENDS: tuple[Backend, ...] = ("process", "docker")


def is_fidelity(value: object) -> TypeGuard[Fidelity]:
    """Whether ``value`` names a fidelity level."""
    return value in FIDELITIES


def check_fidelity(value: object, field: str = "fidelity") -> Fidelity:
    """``value`` as a level; ConfigurationError naming ``field`` if it is none."""
    if not is_fidelity(value):
        raise ConfigurationError(field, value, f"one of {', '.join(map(repr, FIDELITIES))}")
    return value
