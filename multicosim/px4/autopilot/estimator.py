"""The autopilot's state estimator: a GPS-aided attitude and inertial-navigation filter.

Attitude: gyro integration (quaternion, body FRD to NED) corrected towards the specific force
the GPS velocity implies (the DCM approach: over each GPS interval, integrated specific force
must equal the change of GPS velocity minus gravity), or towards gravity when no GPS is
fresh and the vehicle is on the ground, and towards the magnetometer heading.
Position/velocity: accelerations rotated to NED and integrated, pulled towards GPS position
and velocity and towards the height reference.

Height, as PX4's EKF2 with ``EKF2_HGT_REF``: from GNSS (1, PX4's default) with the barometer
as an aid whose offset from GNSS height is tracked (EKF2's height bias), so a barometer that
walks away (weather, a spoof) barely moves the estimate; or from the barometer (0), GNSS
height then taking over only while the barometer is missing or disagrees with it.

Because GPS corrects position and velocity directly, a corrupted GPS (spoofing, noise
attacks) really misleads the estimate, as it misleads PX4's EKF2. Scalar math only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from ...core.geo import GRAVITY, LocalProjection
from .params import Params

__all__ = ["Estimator", "rotation_matrix"]


# Complementary-filter gains (per update at the stated rate).
K_GPS_POS = 0.25  # 10 Hz
K_GPS_VEL = 0.35
K_GPS_VEL_FROM_POS = 0.1
# The vertical loop of GNSS height as stiff as barometric height's (K_BARO_VEL at 50 Hz).
K_GPS_VEL_FROM_POS_Z = 0.05
K_BARO_POS = 0.04  # 50 Hz
K_BARO_VEL = 0.01
K_BARO_VEL_ALONE = 0.05  # without GPS, the barometer alone damps the vertical speed
# With GNSS height the barometer aids weakly (PX4 weighs it by EKF2_BARO_NOISE 3.5 m against
# GNSS's 0.5 m) and its bias follows GNSS height within a few seconds (50 Hz).
K_BARO_AID = 0.004
K_BARO_BIAS = 0.01
HGT_REF_GNSS = 1  # EKF2_HGT_REF; anything else (no range finder, no vision here): barometer
MAG_GATE = 0.5  # rad: a heading innovation beyond this is rejected (a faulty magnetometer)
STUCK_AFTER = 0.25  # s of bit-identical readings after which a sensor is taken as frozen
# Tilt correction gains, rad/s per rad of tilt error. From GPS velocity (each fix's delta-v
# against the integrated specific force) the gain is low: each fix's velocity noise turns the
# attitude by K_TILT * noise / g, and at 2 the attitude shook four times as much as real
# PX4's in the same noisy world. From gravity, on the ground without GPS, a steadier source.
K_TILT = 0.5
K_LEVEL = 1.0
K_YAW = 0.6
GPS_TIMEOUT = 0.5
MAG_TIMEOUT = 0.2  # s: the magnetometer's correction lapses when no sample came for this long


def rotation_matrix(w: float, x: float, y: float, z: float) -> tuple[float, ...]:
    """Row-major rotation matrix of the unit quaternion (w, x, y, z)."""
    return (
        1 - 2 * (y * y + z * z),
        2 * (x * y - w * z),
        2 * (x * z + w * y),
        2 * (x * y + w * z),
        1 - 2 * (x * x + z * z),
        2 * (y * z - w * x),
        2 * (x * z - w * y),
        2 * (y * z + w * x),
        1 - 2 * (x * x + y * y),
    )


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class Estimator:
    """Attitude, local position/velocity (NED from the origin), WGS84 position, health."""

    def __init__(self, declination: float = 0.0, params: Mapping[str, float] | None = None) -> None:
        # Magnetic declination (rad, east of north) where it flies; PX4 looks it up by position.
        self.declination = declination
        # The autopilot's parameters (EKF2_HGT_REF, EKF2_NOAID_TOUT), read where used: they
        # may change in flight.
        self.params: Mapping[str, float] = Params() if params is None else params
        self.q = [1.0, 0.0, 0.0, 0.0]  # w, x, y, z
        self.pos = [0.0, 0.0, 0.0]
        self.vel = [0.0, 0.0, 0.0]
        self.rates = (0.0, 0.0, 0.0)
        self.origin: LocalProjection | None = None
        self.origin_alt = 0.0
        self.baro_offset: float | None = None
        self.attitude_ok = False
        self.last_imu = -1.0
        self.last_mag = -1.0
        self.last_baro = -1.0
        self.last_gps = -1.0
        self.gps_fix = 0
        self.gps_sats = 0
        self.gps_raw = (0, 0, 0, 0, 0, 0, 0)  # lat, lon, alt (mm), eph, epv, vel, cog
        self.gps_ok_since: float | None = None
        self._tilt_corr = (0.0, 0.0, 0.0)  # NED rotation rate, applied between GPS fixes
        self._tilt_until = 0.0  # when the tilt correction lapses
        self._yaw_corr = 0.0
        self._sf_int = [0.0, 0.0, 0.0]
        self._sf_time = 0.0
        self._last_gps_vel: tuple[float, float, float] | None = None
        self._baro_alt = 0.0
        self._baro_bias = 0.0  # barometric height minus GNSS height (down), as tracked
        self._gps_d: float | None = None  # height (down) the last GPS fix gave
        self._baro_bad_since: float | None = None
        self.baro_rejected = False  # barometer inconsistent with GPS: height from GPS
        self._last_reading: dict[str, tuple[object, float]] = {}
        self._acc_b = (0.0, 0.0, -GRAVITY)
        # Whether the vehicle flies (the autopilot's land detector says, as EKF2's in_air).
        self.in_air = False
        self.last_aided = -math.inf  # when a settled GPS fix last aided the position

    # -- derived state ----------------------------------------------------------------------

    def rotation(self) -> tuple[float, ...]:
        """Row-major body-to-NED rotation matrix."""
        return rotation_matrix(*self.q)

    def euler(self) -> tuple[float, float, float]:
        """Roll, pitch, yaw (rad)."""
        w, x, y, z = self.q
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return roll, pitch, yaw

    def gps_ok(self, now: float) -> bool:
        """A 3D fix with enough satellites arrived recently."""
        return self.gps_fix >= 3 and self.gps_sats >= 6 and now - self.last_gps < GPS_TIMEOUT

    def position_ok(self, now: float) -> bool:
        """Horizontal position is GPS-aided and has settled (2 s of good fixes), or, in flight,
        the IMU has carried it on from such a fix for less than EKF2_NOAID_TOUT (PX4's dead
        reckoning)."""
        if self.origin is None:
            return False
        if self.gps_ok(now) and self.gps_ok_since is not None and now - self.gps_ok_since >= 2.0:
            return True
        return self.in_air and now - self.last_aided < self.params["EKF2_NOAID_TOUT"] * 1e-6

    def global_position(self) -> tuple[float, float, float]:
        """Latitude, longitude (deg) and altitude AMSL (m) of the estimate."""
        if self.origin is None:
            return 0.0, 0.0, 0.0
        lat, lon = self.origin.reproject(self.pos[0], self.pos[1])
        return lat, lon, self.origin_alt - self.pos[2]

    # -- sensor updates ---------------------------------------------------------------------

    def imu(
        self,
        now: float,
        dt: float,
        acc: tuple[float, float, float],
        gyro: tuple[float, float, float],
    ) -> None:
        """Propagate attitude and navigation state by ``dt`` with one IMU sample."""
        self.last_imu = now
        self._acc_b = acc
        if not self.attitude_ok:
            self._level(acc)
            self.rates = gyro
            return
        if dt <= 0.0 or dt > 0.2:
            return
        # Corrections are rotation rates in NED, each applied until its sensor's next sample
        # is due: a sensor that falls silent must not leave its last correction turning the
        # estimate (the gyro alone then carries the attitude).
        if now > self._tilt_until:
            self._tilt_corr = (0.0, 0.0, 0.0)
        if now - self.last_mag > MAG_TIMEOUT:
            self._yaw_corr = 0.0
        r = self.rotation()
        cx, cy, cz = self._tilt_corr
        cz += self._yaw_corr
        wx = gyro[0] + r[0] * cx + r[3] * cy + r[6] * cz
        wy = gyro[1] + r[1] * cx + r[4] * cy + r[7] * cz
        wz = gyro[2] + r[2] * cx + r[5] * cy + r[8] * cz
        self.rates = gyro
        w, x, y, z = self.q
        h = 0.5 * dt
        w, x, y, z = (
            w - h * (x * wx + y * wy + z * wz),
            x + h * (w * wx + y * wz - z * wy),
            y + h * (w * wy - x * wz + z * wx),
            z + h * (w * wz + x * wy - y * wx),
        )
        n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
        self.q = [w * n, x * n, y * n, z * n]
        r = self.rotation()
        ax, ay, az = acc
        fn = r[0] * ax + r[1] * ay + r[2] * az
        fe = r[3] * ax + r[4] * ay + r[5] * az
        fd = r[6] * ax + r[7] * ay + r[8] * az
        sf = self._sf_int
        sf[0] += fn * dt
        sf[1] += fe * dt
        sf[2] += fd * dt
        self._sf_time += dt
        # Without GPS to tell acceleration from tilt, the specific force is taken for gravity,
        # but only on the ground: in flight the accelerometer reads the thrust along the body
        # axis whatever the tilt, and taken for gravity it would pull the estimate level through
        # every turn and leave the vehicle flying tilted. Without aiding, PX4's EKF2 too keeps
        # the tilt its gyros give in the air (its fake position fuses at 10 m noise).
        if now - self.last_gps > GPS_TIMEOUT and not self.in_air:
            self._tilt_from(fn, fe, fd, 0.0, 0.0, -GRAVITY, K_LEVEL, now + 2.0 * dt)
        vel, pos = self.vel, self.pos
        vel[0] += fn * dt
        vel[1] += fe * dt
        vel[2] += (fd + GRAVITY) * dt
        pos[0] += vel[0] * dt
        pos[1] += vel[1] * dt
        pos[2] += vel[2] * dt

    def _level(self, acc: tuple[float, float, float]) -> None:
        # Initial roll/pitch from gravity (at rest); yaw follows at the first magnetometer.
        ax, ay, az = acc
        roll = math.atan2(-ay, -az)
        pitch = math.atan2(ax, math.hypot(ay, az))
        self._set_euler(roll, pitch, 0.0)

    def _set_euler(self, roll: float, pitch: float, yaw: float) -> None:
        cr, sr = math.cos(roll / 2), math.sin(roll / 2)
        cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
        cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
        self.q = [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]

    def _tilt_from(
        self,
        fn: float,
        fe: float,
        fd: float,
        en: float,
        ee: float,
        ed: float,
        gain: float,
        until: float,
    ) -> None:
        # Rotation (NED), applied until ``until``, that turns the measured specific force
        # towards the expected one.
        nf = math.sqrt(fn * fn + fe * fe + fd * fd)
        ne = math.sqrt(en * en + ee * ee + ed * ed)
        if nf < 1e-6 or ne < 1e-6:
            return
        fn, fe, fd = fn / nf, fe / nf, fd / nf
        en, ee, ed = en / ne, ee / ne, ed / ne
        self._tilt_until = until
        self._tilt_corr = (
            gain * (fe * ed - fd * ee),
            gain * (fd * en - fn * ed),
            0.0,  # heading is the magnetometer's business
        )

    def _stuck(self, name: str, now: float, reading: object, moving: bool) -> bool:
        """Whether a sensor repeats exactly the same reading where it cannot.

        A reading that cannot repeat while the vehicle turns (magnetometer) or climbs
        (barometer), or while the gyro shows noise (a real sensor's readings never repeat
        bit for bit), is frozen; it is ignored, as PX4's sensor checks drop stale data. An
        ideal sensor on a still vehicle repeats itself legitimately: the ideal gyro then
        reads exactly zero.
        """
        last = self._last_reading.get(name)
        noisy = self.rates != (0.0, 0.0, 0.0)
        if last is None or last[0] != reading or not (moving or noisy):
            self._last_reading[name] = (reading, now)
            return False
        return now - last[1] > STUCK_AFTER

    def mag(self, now: float, m: tuple[float, float, float]) -> None:
        """Correct heading with a magnetometer sample (gauss, FRD)."""
        turning = max(abs(self.rates[0]), abs(self.rates[1]), abs(self.rates[2])) > 0.05
        if self._stuck("mag", now, m, turning):
            return  # its correction lapses (MAG_TIMEOUT): gyro alone
        self.last_mag = now
        r = self.rotation()
        mn = r[0] * m[0] + r[1] * m[1] + r[2] * m[2]
        me = r[3] * m[0] + r[4] * m[1] + r[5] * m[2]
        if mn * mn + me * me < 1e-6:
            return
        err = _wrap(math.atan2(me, mn) - self.declination)
        if not self.attitude_ok:
            roll, pitch, yaw = self.euler()
            self._set_euler(roll, pitch, _wrap(yaw - err))
            self.attitude_ok = True
            return
        # Innovation gate: a heading this far off is the magnetometer's fault, not ours.
        self._yaw_corr = -K_YAW * err if abs(err) < MAG_GATE else 0.0

    def baro(self, now: float, pressure_alt: float) -> None:
        """Correct height with a barometric altitude (m)."""
        if self._stuck("baro", now, pressure_alt, abs(self.vel[2]) > 0.3):
            return
        self.last_baro = now
        self._baro_alt = pressure_alt
        if self.baro_offset is None or self.origin is None:
            return
        d_meas = -(pressure_alt - self.baro_offset - self.origin_alt)
        gps_fresh = self._gps_d is not None and now - self.last_gps < GPS_TIMEOUT
        if self.params["EKF2_HGT_REF"] == HGT_REF_GNSS:
            err = d_meas - self._baro_bias - self.pos[2]
            if gps_fresh:
                # An aid: the bias takes up what the barometer says beyond GNSS height.
                self._baro_bias += K_BARO_BIAS * err
                self.pos[2] += K_BARO_AID * err
            else:
                # GNSS height lost: the barometer carries on from the bias it had.
                self.pos[2] += K_BARO_POS * err
                self.vel[2] += K_BARO_VEL_ALONE * err
            return
        # A stuck or wrong barometer disagrees with GPS for a while: stop fusing it then,
        # as PX4's EKF2 does with its height sources.
        gps_d = self._gps_d
        if gps_d is not None and gps_fresh and abs(d_meas - gps_d) > 8.0:
            if self._baro_bad_since is None:
                self._baro_bad_since = now
            elif now - self._baro_bad_since > 2.0:
                self.baro_rejected = True
        else:
            self._baro_bad_since = None
            self.baro_rejected = False
        if self.baro_rejected:
            return
        err = d_meas - self.pos[2]
        self.pos[2] += K_BARO_POS * err
        alone = now - self.last_gps > GPS_TIMEOUT
        self.vel[2] += (K_BARO_VEL_ALONE if alone else K_BARO_VEL) * err

    def gps(
        self,
        now: float,
        lat_e7: int,
        lon_e7: int,
        alt_mm: int,
        vel_cm: tuple[int, int, int],
        fix: int,
        sats: int,
        eph: int = 0,
        epv: int = 0,
    ) -> None:
        """Correct position and velocity (and tilt) with a GPS fix."""
        self.gps_fix, self.gps_sats = fix, sats
        speed = math.hypot(vel_cm[0], vel_cm[1])
        cog = round(math.degrees(math.atan2(vel_cm[1], vel_cm[0])) * 100) % 36000
        self.gps_raw = (lat_e7, lon_e7, alt_mm, eph, epv, round(speed), cog)
        if fix < 3 or sats < 6:
            self.gps_ok_since = None
            return
        lat, lon, alt = lat_e7 * 1e-7, lon_e7 * 1e-7, alt_mm * 1e-3
        vn, ve, vd = vel_cm[0] * 0.01, vel_cm[1] * 0.01, vel_cm[2] * 0.01
        fresh = now - self.last_gps < GPS_TIMEOUT
        self.last_gps = now
        if self.gps_ok_since is None:
            self.gps_ok_since = now
        if self.origin is None:
            if not self.attitude_ok:
                return
            # The local origin is the first good fix; the barometer is referenced to it.
            self.origin = LocalProjection(lat, lon)
            self.origin_alt = alt
            self.baro_offset = self._baro_alt - alt if self.last_baro >= 0 else 0.0
            self.pos = [0.0, 0.0, 0.0]
            self.vel = [vn, ve, vd]
            self._reset_sf(vn, ve, vd)
            return
        if now - self.gps_ok_since >= 2.0:
            self.last_aided = now
        n, e = self.origin.project(lat, lon)
        pos, vel = self.pos, self.vel
        en, ee = n - pos[0], e - pos[1]
        pos[0] += K_GPS_POS * en
        pos[1] += K_GPS_POS * ee
        vel[0] += K_GPS_VEL * (vn - vel[0]) + K_GPS_VEL_FROM_POS * en
        vel[1] += K_GPS_VEL * (ve - vel[1]) + K_GPS_VEL_FROM_POS * ee
        vel[2] += K_GPS_VEL * 0.5 * (vd - vel[2])
        gps_d = self._gps_d = self.origin_alt - alt
        baro_out = self.last_baro < 0 or now - self.last_baro > 1.0 or self.baro_rejected
        gnss_height = self.params["EKF2_HGT_REF"] == HGT_REF_GNSS
        if gnss_height or baro_out:
            ed = gps_d - pos[2]
            pos[2] += K_GPS_POS * ed
            if gnss_height:
                vel[2] += K_GPS_VEL_FROM_POS_Z * ed
        last = self._last_gps_vel
        if fresh and last is not None and self._sf_time > 0.02:
            t = self._sf_time
            sf = self._sf_int
            # Expected integrated specific force: delta-v minus gravity over the interval.
            self._tilt_from(
                sf[0],
                sf[1],
                sf[2],
                vn - last[0],
                ve - last[1],
                vd - last[2] - GRAVITY * t,
                K_TILT,
                now + 1.5 * t,  # till the next fix is due, with some jitter
            )
        self._reset_sf(vn, ve, vd)

    def _reset_sf(self, vn: float, ve: float, vd: float) -> None:
        self._last_gps_vel = (vn, ve, vd)
        self._sf_int = [0.0, 0.0, 0.0]
        self._sf_time = 0.0

    def reset_altitude_reference(self) -> None:
        """Re-reference height to the current position (not used by default)."""
        self.pos[2] = 0.0
