"""PX4's flight modes as its HEARTBEAT reports them.

PX4 reports its flight mode in HEARTBEAT.custom_mode as ``main_mode << 16 | sub_mode << 24``
(``px4_custom_mode.h``) with MAV_MODE_FLAG_CUSTOM_MODE_ENABLED set in base_mode.
"""

from __future__ import annotations

import enum

__all__ = [
    "MainMode",
    "Mode",
    "SubMode",
    "decode_custom_mode",
    "encode_custom_mode",
    "mode_label",
]


class MainMode(enum.IntEnum):
    """PX4_CUSTOM_MAIN_MODE."""

    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7


class SubMode(enum.IntEnum):
    """PX4_CUSTOM_SUB_MODE_AUTO."""

    NONE = 0
    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6
    FOLLOW_TARGET = 8
    PRECLAND = 9


class Mode(enum.Enum):
    """The flight modes our autopilot implements, as (main, sub) PX4 custom modes."""

    MANUAL = (MainMode.MANUAL, SubMode.NONE)
    ALTCTL = (MainMode.ALTCTL, SubMode.NONE)
    POSCTL = (MainMode.POSCTL, SubMode.NONE)
    ACRO = (MainMode.ACRO, SubMode.NONE)
    OFFBOARD = (MainMode.OFFBOARD, SubMode.NONE)
    STABILIZED = (MainMode.STABILIZED, SubMode.NONE)
    TAKEOFF = (MainMode.AUTO, SubMode.TAKEOFF)
    LOITER = (MainMode.AUTO, SubMode.LOITER)
    MISSION = (MainMode.AUTO, SubMode.MISSION)
    RTL = (MainMode.AUTO, SubMode.RTL)
    LAND = (MainMode.AUTO, SubMode.LAND)
    FOLLOW_TARGET = (MainMode.AUTO, SubMode.FOLLOW_TARGET)
    PRECLAND = (MainMode.AUTO, SubMode.PRECLAND)

    @property
    def custom_mode(self) -> int:
        """The HEARTBEAT custom_mode of this mode."""
        return encode_custom_mode(*self.value)

    @property
    def label(self) -> str:
        """The name ground stations show (``AUTO.MISSION``, ``POSCTL``)."""
        main, sub = self.value
        return main.name if sub == SubMode.NONE else f"{main.name}.{sub.name}"

    @classmethod
    def from_custom(cls, main: int, sub: int) -> Mode | None:
        """The mode encoded as ``main``/``sub``, or None if we do not implement it."""
        for mode in cls:
            m, s = mode.value
            if m == main and (s == sub or (m != MainMode.AUTO and sub == 0)):
                return mode
        return None


def encode_custom_mode(main: int, sub: int) -> int:
    """PX4's custom_mode word for ``main``/``sub`` mode."""
    return (int(main) << 16) | (int(sub) << 24)


def decode_custom_mode(custom_mode: int) -> tuple[int, int]:
    """(main, sub) of a PX4 custom_mode word."""
    return (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF


_labels: dict[int, str] = {}


def mode_label(custom_mode: int) -> str:
    """A readable name for any PX4 custom_mode (``AUTO.MISSION``, ``MANUAL``, ``4.9``)."""
    label = _labels.get(custom_mode)
    if label is None:
        label = _labels[custom_mode] = _mode_label(custom_mode)
    return label


def _mode_label(custom_mode: int) -> str:
    main, sub = decode_custom_mode(custom_mode)
    mode = Mode.from_custom(main, sub)
    if mode is not None:
        return mode.label
    try:
        return MainMode(main).name
    except ValueError:
        return f"{main}.{sub}"
