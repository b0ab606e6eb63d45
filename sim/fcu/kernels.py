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

# state: q (4), gyro bias (3), bias-corrected rate (3), per axis [position, velocity,
# acceleration bias] (9), per axis the symmetric 3x3 covariance (p00, p01, p02, p11, p12,
# p22) (18)
EST_STATE_SIZE = 37
EST_Q, EST_GYRO_BIAS, EST_RATE, EST_X, EST_P = 0, 4, 7, 10, 19
# the output block (the state at EST_OUTPUT_INDEX): position NED (3), velocity NED (3),
# q (4), rate FRD (3), position variance (3), velocity variance (3), acceleration bias (3),
# gyro bias (3)
EST_OUTPUT_SIZE = 25
# buffer row: time [us], x (9), p (18), NED acceleration input (3), dt [s], yaw [rad]
EST_BUF_COLS = 33
_B_X, _B_P, _B_U, _B_DT, _B_YAW = 1, 10, 28, 31, 32
# the attitude filter's accelerometer reference (est_predict's mode)
ATTITUDE_AIDED = 0  # the specific force the filter explains with its position filter's bias
ATTITUDE_GYRO = 1  # none: the gyro alone (dead reckoning)
ATTITUDE_GRAVITY = 2  # gravity (unaided: levelling)
# params: accel correction gain, accel gate, motion compensation, gyro bias gain, gyro bias
# limit, yaw correction fraction, yaw bias gain, accel noise^2, accel bias noise^2
EST_PARAMS_SIZE = 9


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
                        gx: float, gy: float, gz: float, dt: float, mode: int) -> None:
    """Mahony step (see :meth:`sim.fcu.estimator.Estimator._propagate_attitude`)."""
    bx, by, bz = s[4], s[5], s[6]
    r0, r1, r2 = gx - bx, gy - by, gz - bz
    s[7], s[8], s[9] = r0, r1, r2
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    aided = mode == ATTITUDE_AIDED
    if mode != ATTITUDE_GYRO and prm[0] > 0.0 and abs(norm - GRAVITY_M_S2) < prm[1]:
        r = _dcm(s)
        f0 = r[0] * ax + r[1] * ay + r[2] * az - s[12]
        f1 = r[3] * ax + r[4] * ay + r[5] * az - s[15]
        f2 = r[6] * ax + r[7] * ay + r[8] * az - s[18]
        weight = prm[2] if aided else 0.0
        rest = 1.0 - weight
        f0 = weight * f0 + rest * 0.0
        f1 = weight * f1 + rest * 0.0
        f2 = weight * f2 + rest * -GRAVITY_M_S2
        p0 = r[0] * f0 + r[3] * f1 + r[6] * f2
        p1 = r[1] * f0 + r[4] * f1 + r[7] * f2
        p2 = r[2] * f0 + r[5] * f1 + r[8] * f2
        pn = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
        a0, a1, a2 = ax / norm, ay / norm, az / norm
        b0, b1, b2 = p0 / pn, p1 / pn, p2 / pn
        ex = a1 * b2 - a2 * b1
        ey = a2 * b0 - a0 * b2
        ez = a0 * b1 - a1 * b0
        k = prm[0]
        r0, r1, r2 = r0 + k * ex, r1 + k * ey, r2 + k * ez
        kb, lim = prm[3], prm[4]
        s[4] = min(max(bx - kb * ex * dt, -lim), lim)
        s[5] = min(max(by - kb * ey * dt, -lim), lim)
        s[6] = min(max(bz - kb * ez * dt, -lim), lim)
    dw, dx, dy, dz = _q_from_rotation(r0 * dt, r1 * dt, r2 * dt)
    w, x, y, z = _q_multiply(s[0], s[1], s[2], s[3], dw, dx, dy, dz)
    s[0], s[1], s[2], s[3] = _q_normalise(w, x, y, z)


@njit(cache=True)
def _propagate(x: np.ndarray, p: np.ndarray, u0: float, u1: float, u2: float, dt: float,
               qa: float, qb: float) -> None:
    """One Kalman prediction of every axis in place (see
    :meth:`sim.fcu.estimator.Estimator._propagate`)."""
    a, h, g = dt, -0.5 * dt * dt, -dt
    hdt2 = 0.5 * dt * dt
    q00, q01, q11, q22 = qa * dt**3.0 / 3.0, qa * dt * dt / 2.0, qa * dt, qb * dt
    u = (u0, u1, u2)
    for i in range(3):
        j = 3 * i
        pos, vel, bias = x[j], x[j + 1], x[j + 2]
        ui = u[i]
        x[j] = pos + a * vel + h * bias + hdt2 * ui
        x[j + 1] = vel + g * bias + dt * ui
        k = 6 * i
        p00, p01, p02, p11, p12, p22 = p[k], p[k + 1], p[k + 2], p[k + 3], p[k + 4], p[k + 5]
        f00 = p00 + a * p01 + h * p02
        f01 = p01 + a * p11 + h * p12
        f02 = p02 + a * p12 + h * p22
        f11 = p11 + g * p12
        f12 = p12 + g * p22
        p[k] = f00 + a * f01 + h * f02 + q00
        p[k + 1] = f01 + g * f02 + q01
        p[k + 2] = f02
        p[k + 3] = f11 + g * f12 + q11
        p[k + 4] = f12
        p[k + 5] = p22 + q22


@njit(cache=True)
def est_push(buf: np.ndarray, meta: np.ndarray, s: np.ndarray, time_us: float, u0: float,
             u1: float, u2: float, dt: float, horizon_us: float) -> None:
    """Append the state at ``time_us`` to the ring buffer (``meta``: head, count; the
    caller grows a full buffer first), then drop entries older than ``horizon_us`` while
    one older than it remains."""
    cap = buf.shape[0]
    head, count = meta[0], meta[1]
    row = buf[(head + count) % cap]
    row[0] = time_us
    row[_B_X:_B_X + 9] = s[EST_X:EST_X + 9]
    row[_B_P:_B_P + 18] = s[EST_P:EST_P + 18]
    row[_B_U], row[_B_U + 1], row[_B_U + 2] = u0, u1, u2
    row[_B_DT] = dt
    row[_B_YAW] = _q_yaw(s[0], s[1], s[2], s[3])
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
    _propagate_attitude(s, prm, ax, ay, az, gx, gy, gz, dt, mode)
    r = _dcm(s)
    u0 = r[0] * ax + r[1] * ay + r[2] * az
    u1 = r[3] * ax + r[4] * ay + r[5] * az
    u2 = r[6] * ax + r[7] * ay + r[8] * az + GRAVITY_M_S2
    _propagate(s[EST_X:EST_X + 9], s[EST_P:EST_P + 18], u0, u1, u2, dt, prm[7], prm[8])
    est_push(buf, meta, s, time_us, u0, u1, u2, dt, horizon_us)
    return meta[1] == buf.shape[0]


@njit(cache=True)
def _update(x: np.ndarray, p: np.ndarray, state: int, z0: float, z1: float, z2: float,
            r: float) -> None:
    """Scalar measurement of state ``state`` on every axis, in place (see
    :meth:`sim.fcu.estimator.Estimator._update`)."""
    z = (z0, z1, z2)
    for i in range(3):
        k6 = 6 * i
        p00, p01, p02, p11, p12, p22 = (p[k6], p[k6 + 1], p[k6 + 2], p[k6 + 3], p[k6 + 4],
                                        p[k6 + 5])
        if state == 0:
            c0, c1, c2 = p00, p01, p02
            s = c0 + r
        else:
            c0, c1, c2 = p01, p11, p12
            s = c1 + r
        k0, k1, k2 = c0 / s, c1 / s, c2 / s
        j = 3 * i
        pos, vel, bias = x[j], x[j + 1], x[j + 2]
        innovation = z[i] - (pos if state == 0 else vel)
        x[j] = pos + k0 * innovation
        x[j + 1] = vel + k1 * innovation
        x[j + 2] = bias + k2 * innovation
        p[k6] = p00 - k0 * c0
        p[k6 + 1] = p01 - 0.5 * (k0 * c1 + k1 * c0)
        p[k6 + 2] = p02 - 0.5 * (k0 * c2 + k2 * c0)
        p[k6 + 3] = p11 - k1 * c1
        p[k6 + 4] = p12 - 0.5 * (k1 * c2 + k2 * c1)
        p[k6 + 5] = p22 - k2 * c2


@njit(cache=True)
def est_fuse(s: np.ndarray, buf: np.ndarray, meta: np.ndarray, prm: np.ndarray,
             sample_us: float, at_arrival: bool, z0: float, z1: float, z2: float,
             r_pos: float, has_velocity: bool, v0: float, v1: float, v2: float, r_vel: float,
             has_yaw: bool, sample_yaw: float) -> bool:
    """:meth:`sim.fcu.estimator.Estimator.fuse_vision`: rewind to the buffered state at
    ``sample_us``, update, re-propagate the stored inputs to now, correct the heading.
    False (nothing changed) when the sample is older than the buffer."""
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
    x = entry[_B_X:_B_X + 9].copy()
    p = entry[_B_P:_B_P + 18].copy()
    _update(x, p, 0, z0, z1, z2, r_pos)
    if has_velocity:
        _update(x, p, 1, v0, v1, v2, r_vel)
    entry[_B_X:_B_X + 9] = x
    entry[_B_P:_B_P + 18] = p
    for k in range(index + 1, count):
        later = buf[(head + k) % cap]
        _propagate(x, p, later[_B_U], later[_B_U + 1], later[_B_U + 2], later[_B_DT], prm[7],
                   prm[8])
        later[_B_X:_B_X + 9] = x
        later[_B_P:_B_P + 18] = p
    s[EST_X:EST_X + 9] = x
    s[EST_P:EST_P + 18] = p
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
    [EST_X + 3 * i for i in range(3)]  # position NED
    + [EST_X + 3 * i + 1 for i in range(3)]  # velocity NED
    + [EST_Q + i for i in range(4)]  # q
    + [EST_RATE + i for i in range(3)]  # bias-corrected rate FRD
    + [EST_P + 6 * i for i in range(3)]  # position variance (p00 per axis)
    + [EST_P + 6 * i + 3 for i in range(3)]  # velocity variance (p11 per axis)
    + [EST_X + 3 * i + 2 for i in range(3)]  # acceleration bias NED
    + [EST_GYRO_BIAS + i for i in range(3)]  # gyro bias FRD
)
"""Where the output block's values sit in the state (``state[EST_OUTPUT_INDEX]`` is the
block :class:`~sim.fcu.estimator.EstimatorOutput` reads, a copy)."""
assert EST_OUTPUT_INDEX.shape == (EST_OUTPUT_SIZE,)
