"""Sensor intake and PX4's failure injection (MAV_CMD_INJECT_FAILURE with SYS_FAILURE_EN).

A failure acts where PX4's simulator interface acts on it, between the sensors and the
estimator, and is one of [`multicosim.attacks`][multicosim.attacks]' fault models: OFF is a
[`Dropout`][multicosim.attacks.Dropout] from the moment of injection, STUCK repeats the last
reading, OK ends the failure. The same faults injected by an injector participant change
the topics instead; here they change only what this autopilot reads.
"""

from __future__ import annotations

from typing import Any

from ...attacks import Dropout
from ...mavlink.dialect import RESULT_ACCEPTED, RESULT_DENIED, RESULT_UNSUPPORTED
from ...mavlink.hil import BARO_FIELDS, IMU_FIELDS, MAG_FIELDS, HilGps
from .state import State

__all__ = ["FAILURE_UNITS", "Failures"]

# MAV_FAILURE_UNIT -> our sensor name; MAV_FAILURE_TYPE numbers.
FAILURE_UNITS = {0: "gyro", 1: "accel", 2: "mag", 3: "baro", 4: "gps"}
UNIT_MOTOR = 101
FAILURE_OK, FAILURE_OFF, FAILURE_STUCK = 0, 1, 2


class Fault:
    """One injected failure: a Dropout model (OFF) or a held reading (STUCK)."""

    def __init__(self, kind: int, now: float) -> None:
        self.kind = kind
        self.model = Dropout(start=now) if kind == FAILURE_OFF else None
        self.held: Any = None

    def apply(self, reading: Any, time: float) -> Any:
        """The reading the autopilot gets instead (None: none at all)."""
        if self.model is not None:
            return None if self.model.active(time) else reading
        if self.held is None:
            self.held = reading
        return self.held


class Failures(State):
    """Sensor intake with injected failures (a part of ``Autopilot``)."""

    failures: dict[str, Fault]
    _last_imu_us: int | None

    def inject_failure(self, unit: int, kind: int, instance: int) -> int:
        """MAV_CMD_INJECT_FAILURE: the COMMAND_ACK result."""
        if self.params["SYS_FAILURE_EN"] < 0.5:
            return RESULT_DENIED
        if unit == UNIT_MOTOR and kind in (FAILURE_OK, FAILURE_OFF):
            # Motor ``instance`` (1-based) stops, as PX4's failure detector stops it.
            motor = max(instance, 1) - 1
            if kind == FAILURE_OFF:
                self.motors_off.add(motor)
                self._text(f"Failure injected: motor {motor} off")
            else:
                self.motors_off.discard(motor)
            return RESULT_ACCEPTED
        sensor = FAILURE_UNITS.get(unit)
        if sensor is None or kind not in (FAILURE_OK, FAILURE_OFF, FAILURE_STUCK):
            return RESULT_UNSUPPORTED
        if kind == FAILURE_OK:
            self.failures.pop(sensor, None)
        else:
            self.failures[sensor] = Fault(kind, self._now)
            self._text(f"Failure injected: {sensor}")
        return RESULT_ACCEPTED

    def _sensor(self, m: Any) -> None:
        now = m.time_usec * 1e-6
        failures = self.failures
        if type(m) is HilGps:
            fault = failures.get("gps")
            if fault is not None:
                m = fault.apply(m, now)
                if m is None:
                    return
            self.est.gps(
                now,
                m.lat,
                m.lon,
                m.alt,
                (m.vn, m.ve, m.vd),
                m.fix_type,
                m.satellites_visible,
                m.eph,
                m.epv,
            )
            return
        f = m.fields_updated
        if f & IMU_FIELDS == IMU_FIELDS:
            last = self._last_imu_us
            dt = (m.time_usec - last) * 1e-6 if last is not None else 0.0
            self._last_imu_us = m.time_usec
            self.est.imu(now, dt, (m.xacc, m.yacc, m.zacc), (m.xgyro, m.ygyro, m.zgyro))
        if f & MAG_FIELDS == MAG_FIELDS:
            mag = (m.xmag, m.ymag, m.zmag)
            fault = failures.get("mag")
            if fault is not None:
                mag = fault.apply(mag, now)
            if mag is not None:
                self.est.mag(now, mag)
        if f & BARO_FIELDS & 0x800:
            alt = m.pressure_alt
            fault = failures.get("baro")
            if fault is not None:
                alt = fault.apply(alt, now)
            if alt is not None:
                self.est.baro(now, alt)
