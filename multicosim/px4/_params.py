"""The parameters our autopilot exposes over the MAVLink parameter protocol (PX4 names)."""

from __future__ import annotations

__all__ = ["DEFAULTS", "RANGES", "Params"]

# name: (default, min, max). Names, units and meanings follow PX4's.
RANGES: dict[str, tuple[float, float, float]] = {
    "MPC_XY_CRUISE": (5.0, 0.5, 20.0),  # m/s, horizontal speed in missions
    "MPC_Z_VEL_MAX_UP": (3.0, 0.5, 8.0),  # m/s
    "MPC_Z_VEL_MAX_DN": (1.5, 0.5, 4.0),  # m/s
    "MPC_TKO_SPEED": (1.5, 0.5, 5.0),  # m/s, takeoff climb rate
    "MPC_LAND_SPEED": (0.7, 0.2, 3.0),  # m/s, final descent rate
    "MPC_LAND_ALT2": (5.0, 0.0, 100.0),  # m, below this descend at MPC_LAND_SPEED
    "NAV_ACC_RAD": (2.0, 0.05, 200.0),  # m, horizontal acceptance radius
    "NAV_MC_ALT_RAD": (0.8, 0.05, 200.0),  # m, vertical acceptance radius
    "MIS_TAKEOFF_ALT": (2.5, 0.0, 80.0),  # m above home
    "RTL_RETURN_ALT": (30.0, 0.0, 150.0),  # m above home
    "COM_DISARM_LAND": (2.0, -1.0, 20.0),  # s, disarm after landing (< 0: never)
    "COM_DISARM_PRFLT": (10.0, -1.0, 20.0),  # s, disarm if no takeoff after arming
    "COM_POS_FS_DELAY": (1.0, 0.0, 10.0),  # s without GPS before the failsafe
    "GF_MAX_HOR_DIST": (1000.0, 0.0, 10000.0),  # m, 0: no limit
    "GF_MAX_VER_DIST": (120.0, 0.0, 10000.0),  # m, 0: no limit
    "SYS_AUTOSTART": (4001.0, 0.0, 9999999.0),  # the airframe (4001: generic quadrotor x)
}
DEFAULTS = {name: spec[0] for name, spec in RANGES.items()}


class Params(dict[str, float]):
    """Parameter values by name, defaulted, with range checks on set."""

    def __init__(self, values: dict[str, float] | None = None) -> None:
        super().__init__(DEFAULTS)
        for name, value in (values or {}).items():
            if not self.set(name, value):
                from .._errors import ConfigurationError

                lo, hi = RANGES[name][1:] if name in RANGES else (0.0, 0.0)
                raise ConfigurationError(
                    f"params[{name!r}]",
                    value,
                    f"a value in [{lo:g}, {hi:g}]"
                    if name in RANGES
                    else f"one of {', '.join(RANGES)}",
                )

    def set(self, name: str, value: float) -> bool:
        """Set ``name`` if it exists and ``value`` is in range; return whether it was set."""
        spec = RANGES.get(name)
        if spec is None or not (spec[1] <= value <= spec[2]):
            return False
        self[name] = float(value)
        return True

    @property
    def names(self) -> list[str]:
        """Parameter names in index order."""
        return list(RANGES)
