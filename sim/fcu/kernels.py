"""The FCU's per-tick arithmetic, compiled (numba, cached on disk next to this file).

At 500 Hz the rate loop, the mixer and the estimator's prediction run 500 times per
simulated second on 3- and 4-vectors: in Python, the cost is the interpreter's, not the
arithmetic's. The controllers' and the mixer's kernels do the same operations in the same
order as the float code they replaced (``tests/sim/fcu/test_fcu_math_recorded.py`` replays
a recorded flight through them within 1e-6); all hold their state in small float64 arrays
that the owning class
(:class:`~sim.fcu.control.RateController`, :class:`~sim.fcu.estimator.Estimator`, the
mixer) keeps and exposes through its usual API.

``cache=True``: the machine code is written to ``__pycache__`` on first use and loaded
from there afterwards (a clean clone compiles once, in a few seconds).

Pure: numpy and numba (and sim.quadrotor's gravity), no runtime imports.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim.quadrotor import GRAVITY as GRAVITY_M_S2  # a compile-time constant in the kernels

__all__ = [
    "ATTITUDE_AIDED",
    "ATTITUDE_GRAVITY",
    "ATTITUDE_GYRO",
    "ATT_GAINS_SIZE",
    "EST_BUF_COLS",
    "EST_OUTPUT_INDEX",
    "EST_OUTPUT_SIZE",
    "EST_PARAMS_SIZE",
    "EST_STATE_SIZE",
    "RATE_GAINS_SIZE",
    "RATE_STATE_SIZE",
    "attitude_kernel",
    "est_fuse",
    "est_predict",
    "est_push",
    "mix_kernel",
    "rate_kernel",
]


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


# --- attitude controller ------------------------------------------------------------------

# gains: kp (3, yaw compensated for its weight), rate limits (3), yaw weight (1)
ATT_GAINS_SIZE = 7


@njit(cache=True)
def _dcm_column_z(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    return (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))


@njit(cache=True)
def _cross(ax: float, ay: float, az: float, bx: float, by: float,
           bz: float) -> tuple[float, float, float]:
    return (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)


@njit(cache=True)
def _q_between(sx: float, sy: float, sz: float, dx: float, dy: float,
               dz: float) -> tuple[float, float, float, float]:
    """Shortest rotation taking unit vector ``s`` to ``d`` (``matrix::Quaternion(src,
    dst)``; see :func:`sim.fcu.control._quat_between`)."""
    cx, cy, cz = _cross(sx, sy, sz, dx, dy, dz)
    dot = sx * dx + sy * dy + sz * dz
    if cx * cx + cy * cy + cz * cz < 1e-10 and dot < 0.0:
        a0, a1, a2 = abs(sx), abs(sy), abs(sz)
        smallest = min(a0, a1, a2)
        if a0 == smallest:  # the first axis of the smallest component, as list.index
            ex, ey, ez = _cross(sx, sy, sz, 1.0, 0.0, 0.0)
        elif a1 == smallest:
            ex, ey, ez = _cross(sx, sy, sz, 0.0, 1.0, 0.0)
        else:
            ex, ey, ez = _cross(sx, sy, sz, 0.0, 0.0, 1.0)
        return _q_normalise(0.0, ex, ey, ez)
    ss = sx * sx + sy * sy + sz * sz
    dd = dx * dx + dy * dy + dz * dz
    return _q_normalise(dot + math.sqrt(ss * dd), cx, cy, cz)


@njit(cache=True)
def attitude_kernel(g: np.ndarray, qw: float, qx: float, qy: float, qz: float, sw: float,
                    sx: float, sy: float, sz: float,
                    yawspeed_feedforward: float) -> tuple[float, float, float]:
    """:meth:`~sim.fcu.control.AttitudeController.update`: the body-rate setpoint."""
    nw, nx, ny, nz = _q_normalise(qw, qx, qy, qz)
    dw, dx, dy, dz = _q_normalise(sw, sx, sy, sz)
    c0, c1, c2 = _dcm_column_z(nw, nx, ny, nz)
    e0, e1, e2 = _dcm_column_z(dw, dx, dy, dz)
    rw, rx, ry, rz = _q_between(c0, c1, c2, e0, e1, e2)
    if abs(rx) > 1.0 - 1e-5 or abs(ry) > 1.0 - 1e-5:
        rw, rx, ry, rz = dw, dx, dy, dz
    else:
        rw, rx, ry, rz = _q_multiply(rw, rx, ry, rz, nw, nx, ny, nz)
    mw, mx, my, mz = _q_multiply(rw, -rx, -ry, -rz, dw, dx, dy, dz)
    if mw < 0.0:
        mw, mx, my, mz = -mw, -mx, -my, -mz
    w = min(max(mw, -1.0), 1.0)
    z = min(max(mz, -1.0), 1.0)
    yw = g[6]
    tw, tx, ty, tz = _q_multiply(rw, rx, ry, rz, math.cos(yw * math.acos(w)), 0.0, 0.0,
                                 math.sin(yw * math.asin(z)))
    ew, ex, ey, ez = _q_multiply(nw, -nx, -ny, -nz, tw, tx, ty, tz)
    if ew < 0.0:
        ew, ex, ey, ez = -ew, -ex, -ey, -ez
    r0, r1, r2 = 2.0 * ex * g[0], 2.0 * ey * g[1], 2.0 * ez * g[2]
    if math.isfinite(yawspeed_feedforward):
        d0 = 2.0 * (nx * nz - nw * ny)  # the third row of the DCM: world down in the body
        d1 = 2.0 * (ny * nz + nw * nx)
        d2 = 1.0 - 2.0 * (nx * nx + ny * ny)
        r0 += d0 * yawspeed_feedforward
        r1 += d1 * yawspeed_feedforward
        r2 += d2 * yawspeed_feedforward
    return (min(max(r0, -g[3]), g[3]), min(max(r1, -g[4]), g[4]), min(max(r2, -g[5]), g[5]))


# --- rate controller ----------------------------------------------------------------------

# state: integral (3), angular acceleration (3), last rate (3), has last rate (1),
# saturated positive (3), saturated negative (3)
RATE_STATE_SIZE = 16
# gains: kp (3), ki (3), kd (3), integral limits (3), inertia (3), D cutoff [Hz] (1)
RATE_GAINS_SIZE = 16
_INTEGRATOR_RATE_SCALE = math.radians(400.0)  # rad/s, PX4's integrator attenuation


@njit(cache=True)
def rate_kernel(st: np.ndarray, g: np.ndarray, r0: float, r1: float, r2: float,
                s0: float, s1: float, s2: float, dt_us: int,
                landed: bool) -> tuple[float, float, float]:
    """:meth:`~sim.fcu.control.RateController.update`: the torque."""
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
    return (g[12] * acc[0], g[13] * acc[1], g[14] * acc[2])


# --- estimator ----------------------------------------------------------------------------

# state:
# - q (4), gyro bias (3), bias-corrected rate (3);
# - horizontal filter x (8): north, east [m], v north, v east [m/s], tilt error as the
#   acceleration it makes, north and east [m/s^2] (world-fixed), the accelerometer's bias,
#   body x and y [m/s^2] (body-fixed); its covariance P, 8x8 row-major (64);
# - vertical filter x (3): down [m], v down [m/s], acceleration bias down [m/s^2]; its
#   symmetric covariance (p00, p01, p02, p11, p12, p22) (6);
# - the accelerometer bias estimate, FRD (3): the horizontal filter's, and the vertical's
EST_Q, EST_GYRO_BIAS, EST_RATE = 0, 4, 7
EST_H, EST_HP, EST_V, EST_VP, EST_BIAS_OUT = 10, 18, 82, 85, 91
EST_STATE_SIZE = 94
_H_TILT, _H_BIAS = 4, 6  # in the horizontal x
# the output block (the state at EST_OUTPUT_INDEX): position NED (3), velocity NED (3),
# q (4), rate FRD (3), position variance (3), velocity variance (3), accelerometer bias FRD
# (3), gyro bias (3)
EST_OUTPUT_SIZE = 25
# buffer row: time [us], horizontal x (8) and P (64), vertical x (3) and P (6), NED
# acceleration input (3), dt [s], yaw after the step [rad], cos and sin of the yaw the input
# was rotated with, the tilt feedback applied in the step (north, east) [m/s^2]
EST_BUF_COLS = 91
_B_H, _B_HP, _B_V, _B_VP, _B_U, _B_DT, _B_YAW, _B_ROT, _B_FB = 1, 9, 73, 76, 82, 85, 86, 87, 89
# the attitude filter's reference (est_predict's mode)
ATTITUDE_AIDED = 0  # the position filter's tilt error (vision aided): fed back, gyro bias learnt
ATTITUDE_GYRO = 1  # the gyro, and the tilt error the position filter holds (dead reckoning)
ATTITUDE_GRAVITY = 2  # gravity (unaided: levelling)
# params: feedback gain, accel gate, tilt noise^2, gyro bias gain, gyro bias limit, yaw
# correction fraction, yaw bias gain, accel noise^2, vertical accel bias noise^2, body accel
# bias noise^2
EST_PARAMS_SIZE = 10


@njit(cache=True)
def _q_normalise(w: float, x: float, y: float, z: float) -> tuple[float, float, float, float]:
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return (w / n, x / n, y / n, z / n)


@njit(cache=True)
def _q_multiply(pw: float, px: float, py: float, pz: float, qw: float, qx: float, qy: float,
                qz: float) -> tuple[float, float, float, float]:
    return (
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    )


@njit(cache=True)
def _q_from_rotation(rx: float, ry: float, rz: float) -> tuple[float, float, float, float]:
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if angle < 1e-12:
        return (1.0, 0.5 * rx, 0.5 * ry, 0.5 * rz)
    half = 0.5 * angle
    k = math.sin(half) / angle
    return (math.cos(half), k * rx, k * ry, k * rz)


@njit(cache=True)
def _q_yaw(w: float, x: float, y: float, z: float) -> float:
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@njit(cache=True)
def _dcm(s: np.ndarray) -> tuple[float, float, float, float, float, float, float, float,
                                 float]:
    """Row-major rotation matrix of the state's q (normalised first), as a tuple (no heap
    allocation)."""
    w, x, y, z = _q_normalise(s[0], s[1], s[2], s[3])
    return (
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    )


@njit(cache=True)
def _propagate_attitude(s: np.ndarray, prm: np.ndarray, ax: float, ay: float, az: float,
                        gx: float, gy: float, gz: float, dt: float, mode: int,
                        fb: np.ndarray) -> None:
    """One attitude step on the bias-corrected gyro, with the step's tilt correction, and
    the tilt it takes from the position filter into ``fb`` (see
    :meth:`sim.fcu.estimator.Estimator.predict`).

    Aided or dead reckoning: the position filter's tilt error ``t`` [m/s^2] (the horizontal
    specific force the estimate's tilt adds, NED) is a world rotation ``phi`` with
    ``g * (-phi_y, phi_x) = t``; a fraction ``gain * dt`` of it is rotated out of the
    estimate and subtracted from the filter's state (``fb``). The rotation is a Mahony
    correction ``gain * err`` on the rate (``err`` the body-frame angle to remove); aided,
    ``err`` also learns the gyro bias (``- gyro_bias_gain * err * dt``). Gravity: Mahony on
    the accelerometer, less the filter's bias, against gravity while the specific force is
    within the gate of 1 g.

    The bias is not fed back: it enters the horizontal filter's model (rotated by the
    heading), and aided nothing else reads the accelerometer's horizontal axes; the
    unaided gravity reference subtracts it. (Fed into a correction of every sample
    instead, the linear filter gives the same estimates.)
    """
    bx, by, bz = s[4], s[5], s[6]
    r0, r1, r2 = gx - bx, gy - by, gz - bz
    s[7], s[8], s[9] = r0, r1, r2
    fb[0] = fb[1] = 0.0
    k, kb, lim = prm[0], prm[3], prm[4]
    if mode == ATTITUDE_GRAVITY:
        ax = ax - s[EST_H + _H_BIAS]
        ay = ay - s[EST_H + _H_BIAS + 1]
        norm = math.sqrt(ax * ax + ay * ay + az * az)
        if k > 0.0 and abs(norm - GRAVITY_M_S2) < prm[1]:
            r = _dcm(s)
            # the body's view of "down is gravity": R^T (0, 0, -g), normalised
            p0, p1, p2 = -r[6], -r[7], -r[8]
            a0, a1, a2 = ax / norm, ay / norm, az / norm
            ex = a1 * p2 - a2 * p1
            ey = a2 * p0 - a0 * p2
            ez = a0 * p1 - a1 * p0
            r0, r1, r2 = r0 + k * ex, r1 + k * ey, r2 + k * ez
            s[4] = min(max(bx - kb * ex * dt, -lim), lim)
            s[5] = min(max(by - kb * ey * dt, -lim), lim)
            s[6] = min(max(bz - kb * ez * dt, -lim), lim)
    elif k > 0.0:
        tn, te = s[EST_H + _H_TILT], s[EST_H + _H_TILT + 1]
        r = _dcm(s)
        # the world angle to remove, -phi = (-t_e / g, t_n / g, 0), in the body
        wx, wy = -te / GRAVITY_M_S2, tn / GRAVITY_M_S2
        ex = r[0] * wx + r[3] * wy
        ey = r[1] * wx + r[4] * wy
        ez = r[2] * wx + r[5] * wy
        step = min(k * dt, 1.0)  # the fraction removed this step (all of it, at most)
        rate = k if k * dt <= 1.0 else 1.0 / dt
        r0, r1, r2 = r0 + rate * ex, r1 + rate * ey, r2 + rate * ez
        if mode == ATTITUDE_AIDED:
            s[4] = min(max(bx - kb * ex * dt, -lim), lim)
            s[5] = min(max(by - kb * ey * dt, -lim), lim)
            s[6] = min(max(bz - kb * ez * dt, -lim), lim)
        fb[0], fb[1] = step * tn, step * te
    dw, dx, dy, dz = _q_from_rotation(r0 * dt, r1 * dt, r2 * dt)
    w, x, y, z = _q_multiply(s[0], s[1], s[2], s[3], dw, dx, dy, dz)
    s[0], s[1], s[2], s[3] = _q_normalise(w, x, y, z)


@njit(cache=True)
def _propagate_horizontal(x: np.ndarray, p: np.ndarray, un: float, ue: float, dt: float,
                          c: float, sn: float, fb: np.ndarray, qa: float, qt: float,
                          qb: float) -> None:
    """One Kalman prediction of the horizontal filter in place: the step's tilt feedback
    ``fb`` leaves the tilt state first (a known input: the error it corrects went with it),
    then ``a = u - tilt - R(yaw) bias`` drives velocity and position. ``c``, ``sn``: the
    cosine and sine of the yaw ``u`` was rotated to NED with."""
    x[4] -= fb[0]
    x[5] -= fb[1]
    an = un - x[4] - (c * x[6] - sn * x[7])
    ae = ue - x[5] - (sn * x[6] + c * x[7])
    h = 0.5 * dt * dt
    x[0] += dt * x[2] + h * an
    x[1] += dt * x[3] + h * ae
    x[2] += dt * an
    x[3] += dt * ae
    # F = I + (position <- velocity: dt; position <- tilt: -h, <- bias: -h R;
    #          velocity <- tilt: -dt, <- bias: -dt R)
    f = np.zeros((8, 8))
    for i in range(8):
        f[i, i] = 1.0
    for i in range(2):
        f[i, 2 + i] = dt
        f[i, 4 + i] = -h
        f[2 + i, 4 + i] = -dt
    f[0, 6], f[0, 7], f[1, 6], f[1, 7] = -h * c, h * sn, -h * sn, -h * c
    f[2, 6], f[2, 7], f[3, 6], f[3, 7] = -dt * c, dt * sn, -dt * sn, -dt * c
    pm = p.reshape((8, 8))
    fp = np.zeros((8, 8))
    for i in range(8):
        for j in range(8):
            acc = 0.0
            for m in range(8):
                fim = f[i, m]
                if fim != 0.0:
                    acc += fim * pm[m, j]
            fp[i, j] = acc
    for i in range(8):
        for j in range(i, 8):
            acc = 0.0
            for m in range(8):
                fjm = f[j, m]
                if fjm != 0.0:
                    acc += fp[i, m] * fjm
            pm[i, j] = acc
            pm[j, i] = acc
    q00, q01, q11 = qa * dt**3.0 / 3.0, qa * dt * dt / 2.0, qa * dt
    for i in range(2):
        pm[i, i] += q00
        pm[i, 2 + i] += q01
        pm[2 + i, i] += q01
        pm[2 + i, 2 + i] += q11
        pm[4 + i, 4 + i] += qt * dt
        pm[6 + i, 6 + i] += qb * dt


@njit(cache=True)
def _propagate_vertical(x: np.ndarray, p: np.ndarray, u: float, dt: float, qa: float,
                        qb: float) -> None:
    """One Kalman prediction of the vertical filter ``[down, v down, bias]`` in place."""
    a, h, g = dt, -0.5 * dt * dt, -dt
    hdt2 = 0.5 * dt * dt
    q00, q01, q11, q22 = qa * dt**3.0 / 3.0, qa * dt * dt / 2.0, qa * dt, qb * dt
    pos, vel, bias = x[0], x[1], x[2]
    x[0] = pos + a * vel + h * bias + hdt2 * u
    x[1] = vel + g * bias + dt * u
    p00, p01, p02, p11, p12, p22 = p[0], p[1], p[2], p[3], p[4], p[5]
    f00 = p00 + a * p01 + h * p02
    f01 = p01 + a * p11 + h * p12
    f02 = p02 + a * p12 + h * p22
    f11 = p11 + g * p12
    f12 = p12 + g * p22
    p[0] = f00 + a * f01 + h * f02 + q00
    p[1] = f01 + g * f02 + q01
    p[2] = f02
    p[3] = f11 + g * f12 + q11
    p[4] = f12
    p[5] = p22 + q22


@njit(cache=True)
def _bias_out(s: np.ndarray) -> None:
    """The accelerometer bias estimate, FRD: the horizontal filter's, and the vertical
    filter's (down, as the body's z near level)."""
    s[EST_BIAS_OUT] = s[EST_H + _H_BIAS]
    s[EST_BIAS_OUT + 1] = s[EST_H + _H_BIAS + 1]
    s[EST_BIAS_OUT + 2] = s[EST_V + 2]


@njit(cache=True)
def est_push(buf: np.ndarray, meta: np.ndarray, s: np.ndarray, time_us: float, u0: float,
             u1: float, u2: float, dt: float, c: float, sn: float, fb: np.ndarray,
             horizon_us: float) -> None:
    """Append the state at ``time_us`` and the step's inputs to the ring buffer (``meta``:
    head, count; the caller grows a full buffer first), then drop entries older than
    ``horizon_us`` while one older than it remains."""
    cap = buf.shape[0]
    head, count = meta[0], meta[1]
    row = buf[(head + count) % cap]
    row[0] = time_us
    row[_B_H:_B_H + 8] = s[EST_H:EST_H + 8]
    row[_B_HP:_B_HP + 64] = s[EST_HP:EST_HP + 64]
    row[_B_V:_B_V + 3] = s[EST_V:EST_V + 3]
    row[_B_VP:_B_VP + 6] = s[EST_VP:EST_VP + 6]
    row[_B_U], row[_B_U + 1], row[_B_U + 2] = u0, u1, u2
    row[_B_DT] = dt
    row[_B_YAW] = _q_yaw(s[0], s[1], s[2], s[3])
    row[_B_ROT], row[_B_ROT + 1] = c, sn
    row[_B_FB:_B_FB + 2] = fb
    count += 1
    while count > 1 and buf[(head + 1) % cap, 0] <= horizon_us:
        head = (head + 1) % cap
        count -= 1
    meta[0], meta[1] = head, count


@njit(cache=True)
def est_predict(s: np.ndarray, buf: np.ndarray, meta: np.ndarray, prm: np.ndarray,
                time_us: float, dt: float, ax: float, ay: float, az: float, gx: float,
                gy: float, gz: float, mode: int, horizon_us: float) -> bool:
    """:meth:`sim.fcu.estimator.Estimator.predict` after its checks; True when the
    buffer is full afterwards (the caller grows it before the next push)."""
    fb = np.zeros(2)
    _propagate_attitude(s, prm, ax, ay, az, gx, gy, gz, dt, mode, fb)
    r = _dcm(s)
    u0 = r[0] * ax + r[1] * ay + r[2] * az
    u1 = r[3] * ax + r[4] * ay + r[5] * az
    u2 = r[6] * ax + r[7] * ay + r[8] * az + GRAVITY_M_S2
    yaw = math.atan2(r[3], r[0])
    c, sn = math.cos(yaw), math.sin(yaw)
    _propagate_horizontal(s[EST_H:EST_H + 8], s[EST_HP:EST_HP + 64], u0, u1, dt, c, sn, fb,
                          prm[7], prm[2], prm[9])
    _propagate_vertical(s[EST_V:EST_V + 3], s[EST_VP:EST_VP + 6], u2, dt, prm[7], prm[8])
    _bias_out(s)
    est_push(buf, meta, s, time_us, u0, u1, u2, dt, c, sn, fb, horizon_us)
    return meta[1] == buf.shape[0]


@njit(cache=True)
def _update_horizontal(x: np.ndarray, p: np.ndarray, i: int, z: float, r: float) -> None:
    """Scalar measurement of horizontal state ``i`` in place."""
    pm = p.reshape((8, 8))
    s = pm[i, i] + r
    row = pm[i].copy()
    innovation = z - x[i]
    for a in range(8):
        k = row[a] / s
        x[a] += k * innovation
        for b in range(8):
            pm[a, b] -= k * row[b]
    for a in range(8):  # symmetric against rounding
        for b in range(a + 1, 8):
            mean = 0.5 * (pm[a, b] + pm[b, a])
            pm[a, b] = mean
            pm[b, a] = mean


@njit(cache=True)
def _update_vertical(x: np.ndarray, p: np.ndarray, state: int, z: float, r: float) -> None:
    """Scalar measurement of vertical state ``state`` (0 position, 1 velocity) in place."""
    p00, p01, p02, p11, p12, p22 = p[0], p[1], p[2], p[3], p[4], p[5]
    if state == 0:
        c0, c1, c2 = p00, p01, p02
        s = c0 + r
    else:
        c0, c1, c2 = p01, p11, p12
        s = c1 + r
    k0, k1, k2 = c0 / s, c1 / s, c2 / s
    innovation = z - x[state]
    x[0] += k0 * innovation
    x[1] += k1 * innovation
    x[2] += k2 * innovation
    p[0] = p00 - k0 * c0
    p[1] = p01 - 0.5 * (k0 * c1 + k1 * c0)
    p[2] = p02 - 0.5 * (k0 * c2 + k2 * c0)
    p[3] = p11 - k1 * c1
    p[4] = p12 - 0.5 * (k1 * c2 + k2 * c1)
    p[5] = p22 - k2 * c2


@njit(cache=True)
def est_fuse(s: np.ndarray, buf: np.ndarray, meta: np.ndarray, prm: np.ndarray,
             sample_us: float, at_arrival: bool, z0: float, z1: float, z2: float,
             r_pos: float, has_velocity: bool, v0: float, v1: float, v2: float, r_vel: float,
             has_yaw: bool, sample_yaw: float) -> bool:
    """:meth:`sim.fcu.estimator.Estimator.fuse_vision`: rewind to the buffered state at
    ``sample_us``, update, re-propagate the stored inputs (and the feedback each step
    applied) to now, correct the heading. False (nothing changed) when the sample is older
    than the buffer."""
    cap = buf.shape[0]
    head, count = meta[0], meta[1]
    if at_arrival or sample_us >= buf[(head + count - 1) % cap, 0]:
        index = count - 1
    else:  # the last entry at or before the sample (bisect_right - 1)
        lo, hi = 0, count
        while lo < hi:
            mid = (lo + hi) // 2
            if sample_us < buf[(head + mid) % cap, 0]:
                hi = mid
            else:
                lo = mid + 1
        index = lo - 1
        if index < 0:
            return False
    entry = buf[(head + index) % cap]
    xh = entry[_B_H:_B_H + 8].copy()
    ph = entry[_B_HP:_B_HP + 64].copy()
    xv = entry[_B_V:_B_V + 3].copy()
    pv = entry[_B_VP:_B_VP + 6].copy()
    _update_horizontal(xh, ph, 0, z0, r_pos)
    _update_horizontal(xh, ph, 1, z1, r_pos)
    _update_vertical(xv, pv, 0, z2, r_pos)
    if has_velocity:
        _update_horizontal(xh, ph, 2, v0, r_vel)
        _update_horizontal(xh, ph, 3, v1, r_vel)
        _update_vertical(xv, pv, 1, v2, r_vel)
    entry[_B_H:_B_H + 8] = xh
    entry[_B_HP:_B_HP + 64] = ph
    entry[_B_V:_B_V + 3] = xv
    entry[_B_VP:_B_VP + 6] = pv
    for k in range(index + 1, count):
        later = buf[(head + k) % cap]
        _propagate_horizontal(xh, ph, later[_B_U], later[_B_U + 1], later[_B_DT],
                              later[_B_ROT], later[_B_ROT + 1], later[_B_FB:_B_FB + 2],
                              prm[7], prm[2], prm[9])
        _propagate_vertical(xv, pv, later[_B_U + 2], later[_B_DT], prm[7], prm[8])
        later[_B_H:_B_H + 8] = xh
        later[_B_HP:_B_HP + 64] = ph
        later[_B_V:_B_V + 3] = xv
        later[_B_VP:_B_VP + 6] = pv
    s[EST_H:EST_H + 8] = xh
    s[EST_HP:EST_HP + 64] = ph
    s[EST_V:EST_V + 3] = xv
    s[EST_VP:EST_VP + 6] = pv
    _bias_out(s)
    if has_yaw:
        _correct_yaw(s, prm, sample_yaw - entry[_B_YAW])
    return True


@njit(cache=True)
def _correct_yaw(s: np.ndarray, prm: np.ndarray, innovation: float) -> None:
    error = (innovation + math.pi) % (2.0 * math.pi) - math.pi
    tw, tx, ty, tz = _q_from_rotation(0.0, 0.0, prm[5] * error)
    w, x, y, z = _q_multiply(tw, tx, ty, tz, s[0], s[1], s[2], s[3])
    w, x, y, z = _q_normalise(w, x, y, z)
    s[0], s[1], s[2], s[3] = w, x, y, z
    d0 = 2.0 * (x * z - w * y)
    d1 = 2.0 * (y * z + w * x)
    d2 = 1.0 - 2.0 * (x * x + y * y)
    k, lim = prm[6] * error, prm[4]
    s[4] = min(max(s[4] - k * d0, -lim), lim)
    s[5] = min(max(s[5] - k * d1, -lim), lim)
    s[6] = min(max(s[6] - k * d2, -lim), lim)


EST_OUTPUT_INDEX = np.array(
    [EST_H, EST_H + 1, EST_V]  # position NED
    + [EST_H + 2, EST_H + 3, EST_V + 1]  # velocity NED
    + [EST_Q + i for i in range(4)]  # q
    + [EST_RATE + i for i in range(3)]  # bias-corrected rate FRD
    + [EST_HP, EST_HP + 9, EST_VP]  # position variance
    + [EST_HP + 18, EST_HP + 27, EST_VP + 3]  # velocity variance
    + [EST_BIAS_OUT + i for i in range(3)]  # accelerometer bias FRD
    + [EST_GYRO_BIAS + i for i in range(3)]  # gyro bias FRD
)
"""Where the output block's values sit in the state (``state[EST_OUTPUT_INDEX]`` is the
block :class:`~sim.fcu.estimator.EstimatorOutput` reads, a copy)."""
assert EST_OUTPUT_INDEX.shape == (EST_OUTPUT_SIZE,)

