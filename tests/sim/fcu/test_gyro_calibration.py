"""The FCU's gyro calibration at rest: the mean rate of a still, disarmed IMU is its bias."""

from __future__ import annotations

import numpy as np

from sim.fcu.gyro_calibration import GyroCalibration
from sim.quadrotor import GRAVITY, ImuNoiseModel, ImuNoiseParams

PERIOD_US = 2_000  # 500 Hz
WINDOW_US = 2_000_000
AT_REST_FLU = [0.0, 0.0, GRAVITY, 0.0, 0.0, 0.0]  # specific force up, no rotation


def _calibration() -> GyroCalibration:
    return GyroCalibration(WINDOW_US, rest_rate_rad_s=0.05, rest_accel_m_s2=0.3)


def _frd(values: list[float]) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    ax, ay, az, gx, gy, gz = values
    return (ax, -ay, -az), (gx, -gy, -gz)


def test_a_still_disarmed_imu_gives_its_gyro_bias_each_window() -> None:
    imu = ImuNoiseModel(ImuNoiseParams(), np.random.default_rng(3))
    cal = _calibration()
    found = []
    for k in range(1, 2 * WINDOW_US // PERIOD_US + 3):
        accel, gyro = _frd(imu.noisy_values(AT_REST_FLU, PERIOD_US / 1e6))
        bias = cal.update(k * PERIOD_US, gyro, accel, armed=False)
        if bias is not None:
            found.append((k * PERIOD_US, np.array(bias)))
    assert [t for t, _ in found] == [WINDOW_US + PERIOD_US, 2 * WINDOW_US + 2 * PERIOD_US]
    true_frd = imu.gyro_bias * np.array([1.0, -1.0, -1.0])
    # the turn-on bias is 5 mrad/s (std); 2 s of 170 urad/s/sqrt(Hz) noise average to 0.12
    assert np.abs(true_frd).max() > 1e-3
    for _, bias in found:
        assert np.abs(bias - true_frd).max() < 0.5e-3, (bias, true_frd)


def test_armed_or_moving_gives_nothing_and_starts_the_window_again() -> None:
    cal = _calibration()
    level = (0.0, 0.0, -GRAVITY)
    still = (0.001, 0.0, 0.0)
    t = 0
    for _ in range(2 * WINDOW_US // PERIOD_US):
        t += PERIOD_US
        assert cal.update(t, still, level, armed=True) is None
    for _ in range(WINDOW_US // PERIOD_US - 10):
        t += PERIOD_US
        assert cal.update(t, still, level, armed=False) is None
    t += PERIOD_US
    assert cal.update(t, (0.2, 0.0, 0.0), level, armed=False) is None  # picked up: moving
    for _ in range(WINDOW_US // PERIOD_US):
        t += PERIOD_US
        assert cal.update(t, still, level, armed=False) is None, "a new window, not done yet"
    t += PERIOD_US
    bias = cal.update(t, still, level, armed=False)
    assert bias is not None and np.allclose(bias, still, rtol=0.0, atol=1e-15)
    assert cal.update(t + PERIOD_US, still, (0.0, 0.0, -GRAVITY - 1.0), armed=False) is None
    assert cal.calibrations == 1
    assert GyroCalibration(0, 0.05, 0.3).update(t, still, level, armed=False) is None
