"""The simulated FCU's gyro calibration at rest (PX4's ``gyro_calibration`` module).

PX4 learns the gyro offsets whenever the vehicle is disarmed and still: the rates it
reads then are the sensor's bias (and noise), so their mean over a window is the bias,
known far better than an attitude filter learns it in flight. The estimator starts its
flight from it (:meth:`sim.fcu.estimator.Estimator.set_gyro_bias`).

Why it matters: the attitude filter learns the bias slowly (``gyro_bias_gain``: a time
constant of about 100 s); 25 s after boot its roll-rate bias can still be 6 mrad/s off,
which dead reckoning turns into a tilt growing 0.34 deg/s once vision stops.
"""

from __future__ import annotations

import math

from sim.fcu.control import Vec3
from sim.quadrotor import GRAVITY

__all__ = ["GyroCalibration"]


class GyroCalibration:
    """Means the gyro over ``window_us`` while disarmed and at rest; a window with any
    sample not at rest (a rate above ``rest_rate_rad_s``, or a specific force off 1 g by
    more than ``rest_accel_m_s2``) or armed starts again."""

    def __init__(self, window_us: int, rest_rate_rad_s: float, rest_accel_m_s2: float) -> None:
        self.window_us = window_us
        self.rest_rate_rad_s = rest_rate_rad_s
        self.rest_accel_m_s2 = rest_accel_m_s2
        self._start_us: int | None = None
        self._sum = [0.0, 0.0, 0.0]
        self._n = 0
        self.calibrations = 0  # windows completed

    def _restart(self, now_us: int | None) -> None:
        self._start_us = now_us
        self._sum = [0.0, 0.0, 0.0]
        self._n = 0

    def update(self, now_us: int, gyro_frd: Vec3, accel_frd: Vec3, armed: bool) -> Vec3 | None:
        """One IMU sample [rad/s, m/s^2, FRD]; the bias [rad/s, FRD] when a window at rest
        completes, else None."""
        if self.window_us <= 0:
            return None
        gx, gy, gz = gyro_frd
        ax, ay, az = accel_frd
        rest = (not armed and max(abs(gx), abs(gy), abs(gz)) < self.rest_rate_rad_s
                and abs(math.sqrt(ax * ax + ay * ay + az * az) - GRAVITY) < self.rest_accel_m_s2)
        if not rest:
            self._restart(None)
            return None
        if self._start_us is None:
            self._restart(now_us)
        s = self._sum
        s[0] += gx
        s[1] += gy
        s[2] += gz
        self._n += 1
        assert self._start_us is not None
        if now_us - self._start_us < self.window_us:
            return None
        n = self._n
        bias = (s[0] / n, s[1] / n, s[2] / n)
        self._restart(None)
        self.calibrations += 1
        return bias
