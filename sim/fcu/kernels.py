"""The FCU's per-tick arithmetic, compiled (numba, cached on disk next to this file).

At 500 Hz the rate loop, the mixer and the estimator's prediction run 500 times per
simulated second on 3- and 4-vectors: in Python, the cost is the interpreter's, not the
arithmetic's. These kernels do the same operations in the same order as the float code
they replaced (``tests/sim/fcu/test_fcu_math_recorded.py`` replays a recorded flight
through them within 1e-6), on state held in small float64 arrays that the owning class
(:class:`~sim.fcu.control.RateController`, :class:`~sim.fcu.estimator.Estimator`, the
mixer) keeps and exposes through its usual API.

``cache=True``: the machine code is written to ``__pycache__`` on first use and loaded
from there afterwards (a clean clone compiles once, in a few seconds).

Pure: numpy and numba, no runtime imports.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "EST_BUF_COLS",
    "EST_STATE_SIZE",
    "est_fuse",
    "est_predict",
    "mix_kernel",
    "rate_kernel",
]

GRAVITY_M_S2 = 9.80665  # checked against sim.quadrotor.GRAVITY by the estimator

# --- mixer --------------------------------------------------------------------------------


@njit(cache=True)
def _desaturation_gain(vector: np.ndarray, sp: np.ndarray, lo: float, hi: float) -> float:
    k_min = 0.0
    k_max = 0.0
    for i in range(4):
        v = vector[i]
        s = sp[i]
        if abs(v) < 1e-7:
            continue
        if s < lo:
            k = (lo - s) / v
            k_min = min(k_min, k)
            k_max = max(k_max, k)
        if s > hi:
            k = (hi - s) / v
            k_min = min(k_min, k)
            k_max = max(k_max, k)
    return k_min + k_max


@njit(cache=True)
def _desaturate(sp: np.ndarray, vector: np.ndarray, lo: float, hi: float,
                min_gain: float) -> float:
    """PX4 ``desaturateActuators`` in place on ``sp``; returns the total gain."""
    if lo <= sp.min() and sp.max() <= hi:
        return 0.0
    total = 0.0
    for scale in (1.0, 0.5):
        gain = scale * _desaturation_gain(vector, sp, lo, hi)
        gain = min(max(gain, min_gain - total), -total)
        for i in range(4):
            sp[i] = sp[i] + gain * vector[i]
        total += gain
    return total


@njit(cache=True)
def mix_kernel(cols: np.ndarray, collective: float, tx: float, ty: float, tz: float,
               lo: float, hi: float, out: np.ndarray) -> None:
    """:func:`~sim.fcu.control.mix_with_desaturation`: ``cols`` rows are the rotor thrusts
    per unit collective thrust and FLU torque x, y, z; ``out`` receives the four clipped
    rotor thrusts, the achieved collective thrust, then 1.0/0.0 flags saturated positive
    (3) and negative (3)."""
    col_thrust = cols[0]
    col_roll = np.empty(4)
    col_pitch = np.empty(4)
    col_yaw = np.empty(4)
    sp = np.empty(4)
    for i in range(4):
        col_roll[i] = cols[1, i] * tx  # FRD -> FLU: y and z negated
        col_pitch[i] = cols[2, i] * -ty
        col_yaw[i] = cols[3, i] * -tz
        sp[i] = col_thrust[i] * collective + col_roll[i] + col_pitch[i]
    no_thrust = -max(collective, 0.0)
    gain_t1 = _desaturate(sp, col_thrust, lo, hi, no_thrust)
    gain_roll = _desaturate(sp, col_roll, lo, hi, -1.0)
    gain_pitch = _desaturate(sp, col_pitch, lo, hi, -1.0)
    for i in range(4):
        sp[i] = sp[i] + col_yaw[i]
    gain_yaw = _desaturate(sp, col_yaw, lo, hi + 0.15 * (hi - lo), -1.0)
    gain_t2 = _desaturate(sp, col_thrust, lo, hi, no_thrust - gain_t1)
    for i in range(4):
        out[i] = min(max(sp[i], lo), hi)
    out[4] = collective + gain_t1 + gain_t2
    reduced = (gain_roll < -1e-6, gain_pitch < -1e-6, gain_yaw < -1e-6)
    torque = (tx, ty, tz)
    for i in range(3):
        out[5 + i] = 1.0 if reduced[i] and torque[i] > 0.0 else 0.0
        out[8 + i] = 1.0 if reduced[i] and torque[i] < 0.0 else 0.0


# --- rate controller ----------------------------------------------------------------------

# state: integral (3), angular acceleration (3), last rate (3), has last rate (1),
# saturated positive (3), saturated negative (3)
RATE_STATE_SIZE = 16
# gains: kp (3), ki (3), kd (3), integral limits (3), inertia (3), D cutoff [Hz] (1)
RATE_GAINS_SIZE = 16
_INTEGRATOR_RATE_SCALE = math.radians(400.0)  # rad/s, PX4's integrator attenuation


@njit(cache=True)
def rate_kernel(st: np.ndarray, g: np.ndarray, r0: float, r1: float, r2: float,
                s0: float, s1: float, s2: float, dt_us: int, landed: bool,
                out: np.ndarray) -> None:
    """:meth:`~sim.fcu.control.RateController.update`: ``out`` receives the torque."""
    dt = max(dt_us, 1) / 1_000_000
    rate = (r0, r1, r2)
    rate_sp = (s0, s1, s2)
    if st[9] != 0.0:
        alpha = 1.0 - math.exp(-2.0 * math.pi * g[15] * dt)
        for i in range(3):
            raw = (rate[i] - st[6 + i]) / dt
            st[3 + i] += alpha * (raw - st[3 + i])
    for i in range(3):
        st[6 + i] = rate[i]
    st[9] = 1.0
    acc = np.empty(3)
    error = np.empty(3)
    for i in range(3):
        error[i] = rate_sp[i] - rate[i]
        acc[i] = g[i] * error[i] + st[i] - g[6 + i] * st[3 + i]
    if not landed:
        candidate = np.empty(3)
        finite = True
        for i in range(3):
            e = error[i]
            if st[10 + i] != 0.0:
                e = min(e, 0.0)
            if st[13 + i] != 0.0:
                e = max(e, 0.0)
            factor = max(0.0, 1.0 - (e / _INTEGRATOR_RATE_SCALE) ** 2)
            candidate[i] = st[i] + factor * g[3 + i] * e * dt
            finite = finite and math.isfinite(candidate[i])
        if finite:
            for i in range(3):
                st[i] = min(max(candidate[i], -g[9 + i]), g[9 + i])
    for i in range(3):
        out[i] = g[12 + i] * acc[i]
