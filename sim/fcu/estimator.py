"""State estimator of the simulated FCU: attitude filter + delayed-fusion position filter.

Pure numpy; frames as on the FCU (world NED, body FRD, ``q_ned_frd`` Hamilton
``[w, x, y, z]``); time is the FCU clock in integer microseconds.

* Attitude: a Mahony complementary filter. Gyro integration with a gyro-bias estimate;
  the accelerometer pulls roll and pitch towards gravity only while the specific force is
  within ``accel_gate`` of 1 g; external-vision yaw corrects the heading.
* Position and velocity: three independent per-axis Kalman filters (NED x, y, z), each
  with state ``[position, velocity, acceleration bias]``, driven by the IMU specific
  force rotated to NED with gravity removed, and fusing external-vision position (and
  velocity, when given).
* Delay: like EKF2's buffers, a bounded history (``buffer_length_us``) of (time, filter
  state, covariance, IMU input) is kept. A vision sample is fused at its own sample time:
  the filter rewinds to the buffered state at that time, updates, and re-propagates the
  stored IMU inputs to now. ``fuse_at_arrival=True`` ignores the sample time (the naive
  estimator, for comparison). The heading correction uses the yaw buffered at the
  sample time the same way.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from runtime.parameters import param, validate_parameters
from sim.fcu.control import (
    Quat,
    Vec3,
    VehicleState,
    _f_cross,
    _fq_dcm_row_z,
    _fq_multiply,
    _fq_normalise,
    _fq_yaw,
)
from sim.quadrotor import GRAVITY

__all__ = [
    "ESTIMATOR_NODE_NAME",
    "Estimator",
    "EstimatorOutput",
    "EstimatorParams",
    "VisionSample",
]

FloatArray = npt.NDArray[np.float64]
ESTIMATOR_NODE_NAME = "fcu_estimator"
_US_PER_S = 1_000_000


@dataclass(frozen=True)
class EstimatorParams:
    """Tuning of the estimator (``config/fcu_estimator.yaml``); ranges declared once."""

    accel_correction_gain: float = param(unit="1/s", range=(0.0, 20.0))
    accel_gate: float = param(unit="m/s^2", range=(0.0, 10.0))
    motion_compensation: float = param(unit="-", range=(0.0, 1.0))
    gyro_bias_gain: float = param(unit="1/s^2", range=(0.0, 10.0))
    gyro_bias_limit: float = param(unit="rad/s", range=(0.0, 1.0))
    yaw_correction_fraction: float = param(unit="per vision sample", range=(0.0, 1.0))
    yaw_bias_gain: float = param(unit="1/s per vision sample", range=(0.0, 10.0))
    accel_noise: float = param(unit="m/s^2/sqrt(Hz)", range=(1e-4, 100.0))
    accel_bias_noise: float = param(unit="m/s^3/sqrt(Hz)", range=(0.0, 10.0))
    vision_position_std: float = param(unit="m", range=(1e-4, 100.0))
    vision_velocity_std: float = param(unit="m/s", range=(1e-4, 100.0))
    initial_position_std: float = param(unit="m", range=(1e-3, 1000.0))
    initial_velocity_std: float = param(unit="m/s", range=(1e-3, 100.0))
    initial_accel_bias_std: float = param(unit="m/s^2", range=(0.0, 10.0))
    buffer_length_us: int = param(unit="us", range=(1_000, 10_000_000))
    vision_timeout_us: int = param(unit="us", range=(1_000, 100_000_000))

    def __post_init__(self) -> None:
        validate_parameters(self)


@dataclass(frozen=True)
class VisionSample:
    """An external-vision pose (``/fmu/in/vehicle_visual_odometry``), NED/FRD.

    ``sample_time_us`` is when the pose was true (FCU clock), not when it arrived.
    ``q`` and ``velocity_ned`` are optional; a variance of NaN uses the configured std.
    """

    sample_time_us: int
    position_ned: FloatArray  # m
    q: FloatArray | None = None  # q_ned_frd; only its yaw is used
    velocity_ned: FloatArray | None = None  # m/s
    position_variance: float = math.nan  # m^2
    velocity_variance: float = math.nan  # (m/s)^2


@dataclass(frozen=True)
class EstimatorOutput:
    """The estimate at ``time_us``, its variances and health flags."""

    time_us: int
    state: VehicleState
    position_variance_ned: FloatArray  # m^2
    velocity_variance_ned: FloatArray  # (m/s)^2
    accel_bias_ned: FloatArray  # m/s^2
    gyro_bias_frd: FloatArray  # rad/s
    position_valid: bool  # vision fused within vision_timeout_us
    dead_reckoning_time_us: int  # since the last fused vision sample (0 right after one)
    vision_fused: int  # count of fused samples
    vision_rejected: int  # count of samples older than the buffer


@dataclass
class _Entry:
    """One buffered step: the filter state after propagating to ``time_us``."""

    time_us: int
    x: _AxisStates  # per axis (position, velocity, acceleration bias)
    p: _AxisCovs  # per axis, the symmetric 3x3 as (p00, p01, p02, p11, p12, p22)
    u: Vec3  # NED acceleration input over the step [m/s^2]
    dt_s: float
    yaw: float  # attitude filter yaw at time_us [rad]


_AxisState = tuple[float, float, float]
_AxisStates = tuple[_AxisState, _AxisState, _AxisState]
_AxisCov = tuple[float, float, float, float, float, float]
_AxisCovs = tuple[_AxisCov, _AxisCov, _AxisCov]


def _wrap_pi(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _quat_from_rotation(rx: float, ry: float, rz: float) -> Quat:
    """:func:`~sim.fcu.control.quat_from_axis_angle` on floats."""
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if angle < 1e-12:
        return (1.0, 0.5 * rx, 0.5 * ry, 0.5 * rz)
    half = 0.5 * angle
    k = math.sin(half) / angle
    return (math.cos(half), k * rx, k * ry, k * rz)


def _dcm(q: Quat) -> tuple[float, ...]:
    """Row-major ``quat_to_dcm(q)`` (normalised first)."""
    w, x, y, z = _fq_normalise(q)
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y),
            2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x),
            2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y))


class Estimator:
    """Attitude complementary filter + per-axis position/velocity Kalman filters.

    Feed IMU samples with :meth:`predict` (body FRD specific force and rate) and vision
    samples with :meth:`fuse_vision`; read :meth:`output`. The arithmetic runs on Python
    floats (numpy's per-call cost dominates on 3-vectors); ``tests/sim/fcu/
    test_fcu_math_recorded.py`` holds it within 1e-6 of the numpy version it replaced.
    """

    def __init__(
        self,
        params: EstimatorParams,
        *,
        fuse_at_arrival: bool = False,
        position_ned: npt.ArrayLike = (0.0, 0.0, 0.0),
        q: npt.ArrayLike = (1.0, 0.0, 0.0, 0.0),
        time_us: int = 0,
    ) -> None:
        self.params = params
        self.fuse_at_arrival = fuse_at_arrival
        self._qa = params.accel_noise**2
        self._qb = params.accel_bias_noise**2
        self.reset(time_us, position_ned, q)

    def reset(
        self,
        time_us: int,
        position_ned: npt.ArrayLike = (0.0, 0.0, 0.0),
        q: npt.ArrayLike = (1.0, 0.0, 0.0, 0.0),
    ) -> None:
        """Restart at ``time_us`` from a prior position [m, NED] and attitude (q_ned_frd)."""
        prm = self.params
        self._time_us = time_us
        q_list = np.asarray(q, dtype=np.float64).reshape(4).tolist()
        self._q: Quat = _fq_normalise((q_list[0], q_list[1], q_list[2], q_list[3]))
        self._gyro_bias: Vec3 = (0.0, 0.0, 0.0)
        self._rate: Vec3 = (0.0, 0.0, 0.0)
        n, e, d = np.asarray(position_ned, dtype=np.float64).reshape(3).tolist()
        self._x: _AxisStates = ((n, 0.0, 0.0), (e, 0.0, 0.0), (d, 0.0, 0.0))
        p0: _AxisCov = (prm.initial_position_std**2, 0.0, 0.0, prm.initial_velocity_std**2,
                        0.0, prm.initial_accel_bias_std**2)
        self._p: _AxisCovs = (p0, p0, p0)
        self._last_vision_us: int | None = None
        self._fused = 0
        self._rejected = 0
        self._buffer: deque[_Entry] = deque()
        self._buffer.append(_Entry(time_us, self._x, self._p, (0.0, 0.0, 0.0), 0.0,
                                   _fq_yaw(self._q)))

    # --- prediction -----------------------------------------------------------------------

    def predict(self, time_us: int, accel_frd: npt.ArrayLike, gyro_frd: npt.ArrayLike) -> None:
        """Propagate to ``time_us`` with an IMU sample (specific force m/s^2, rate rad/s, FRD)."""
        if time_us <= self._time_us:
            raise ValueError(f"time_us: {time_us} is not after the last sample ({self._time_us})")
        dt = (time_us - self._time_us) / _US_PER_S
        self._time_us = time_us
        ax, ay, az = np.asarray(accel_frd, dtype=np.float64).tolist()
        gx, gy, gz = np.asarray(gyro_frd, dtype=np.float64).tolist()
        self._propagate_attitude((ax, ay, az), (gx, gy, gz), dt)
        r = _dcm(self._q)
        u: Vec3 = (r[0] * ax + r[1] * ay + r[2] * az,
                   r[3] * ax + r[4] * ay + r[5] * az,
                   r[6] * ax + r[7] * ay + r[8] * az + GRAVITY)
        self._x, self._p = self._propagate(self._x, self._p, u, dt)
        buffer = self._buffer
        buffer.append(_Entry(time_us, self._x, self._p, u, dt, _fq_yaw(self._q)))
        horizon = time_us - self.params.buffer_length_us
        while len(buffer) > 1 and buffer[1].time_us <= horizon:
            buffer.popleft()

    def _propagate_attitude(self, accel: Vec3, gyro: Vec3, dt: float) -> None:
        """Mahony step. The accelerometer's reference is the specific force the position
        filter believes in, ``R f - b`` (gravity plus the vehicle's own acceleration,
        ``motion_compensation`` of it): a tilt error shows up there as a horizontal
        acceleration bias, which vision makes observable."""
        prm = self.params
        bx, by, bz = self._gyro_bias
        rate = (gyro[0] - bx, gyro[1] - by, gyro[2] - bz)
        self._rate = rate
        ax, ay, az = accel
        norm = math.sqrt(ax * ax + ay * ay + az * az)
        if prm.accel_correction_gain > 0.0 and abs(norm - GRAVITY) < prm.accel_gate:
            r = _dcm(self._q)
            x = self._x
            ref = (r[0] * ax + r[1] * ay + r[2] * az - x[0][2],
                   r[3] * ax + r[4] * ay + r[5] * az - x[1][2],
                   r[6] * ax + r[7] * ay + r[8] * az - x[2][2])
            # without vision the filter's acceleration is not observable: trust gravity
            weight = prm.motion_compensation if self._aided() else 0.0
            rest = 1.0 - weight
            ref = (weight * ref[0] + rest * 0.0, weight * ref[1] + rest * 0.0,
                   weight * ref[2] + rest * -GRAVITY)
            pred = (r[0] * ref[0] + r[3] * ref[1] + r[6] * ref[2],
                    r[1] * ref[0] + r[4] * ref[1] + r[7] * ref[2],
                    r[2] * ref[0] + r[5] * ref[1] + r[8] * ref[2])
            pn = math.sqrt(pred[0] * pred[0] + pred[1] * pred[1] + pred[2] * pred[2])
            ex, ey, ez = _f_cross((ax / norm, ay / norm, az / norm),
                                  (pred[0] / pn, pred[1] / pn, pred[2] / pn))
            k = prm.accel_correction_gain
            rate = (rate[0] + k * ex, rate[1] + k * ey, rate[2] + k * ez)
            kb, lim = prm.gyro_bias_gain, prm.gyro_bias_limit
            self._gyro_bias = (min(max(bx - kb * ex * dt, -lim), lim),
                               min(max(by - kb * ey * dt, -lim), lim),
                               min(max(bz - kb * ez * dt, -lim), lim))
        q = _fq_multiply(self._q, _quat_from_rotation(rate[0] * dt, rate[1] * dt, rate[2] * dt))
        self._q = _fq_normalise(q)

    def _aided(self) -> bool:
        """Vision fused within ``vision_timeout_us``."""
        last = self._last_vision_us
        return last is not None and self._time_us - last <= self.params.vision_timeout_us

    def _propagate(
        self, x: _AxisStates, p: _AxisCovs, u: Vec3, dt: float
    ) -> tuple[_AxisStates, _AxisCovs]:
        """One Kalman prediction of every axis over ``dt`` [s] with NED acceleration ``u``:
        ``x' = F x + [dt^2/2, dt, 0] u``, ``P' = F P F^T + Q`` with
        ``F = [[1, dt, -dt^2/2], [0, 1, -dt], [0, 0, 1]]``."""
        a, h, g = dt, -0.5 * dt * dt, -dt
        hdt2 = 0.5 * dt * dt
        qa, qb = self._qa, self._qb
        q00, q01, q11, q22 = qa * dt**3 / 3.0, qa * dt * dt / 2.0, qa * dt, qb * dt
        xs = []
        ps = []
        for i in range(3):
            pos, vel, bias = x[i]
            ui = u[i]
            xs.append((pos + a * vel + h * bias + hdt2 * ui, vel + g * bias + dt * ui, bias))
            p00, p01, p02, p11, p12, p22 = p[i]
            # rows of F P (P symmetric)
            f00 = p00 + a * p01 + h * p02
            f01 = p01 + a * p11 + h * p12
            f02 = p02 + a * p12 + h * p22
            f11 = p11 + g * p12
            f12 = p12 + g * p22
            ps.append((f00 + a * f01 + h * f02 + q00, f01 + g * f02 + q01, f02,
                       f11 + g * f12 + q11, f12, p22 + q22))
        return (xs[0], xs[1], xs[2]), (ps[0], ps[1], ps[2])

    # --- vision fusion ----------------------------------------------------------------------

    def fuse_vision(self, sample: VisionSample) -> bool:
        """Fuse an external-vision sample; False when it is older than the buffer."""
        prm = self.params
        buffer = self._buffer
        if self.fuse_at_arrival or sample.sample_time_us >= buffer[-1].time_us:
            index = len(buffer) - 1
        else:
            times = [entry.time_us for entry in buffer]
            index = bisect.bisect_right(times, sample.sample_time_us) - 1
            if index < 0:
                self._rejected += 1
                return False
        entry = buffer[index]
        x, p = entry.x, entry.p
        r_pos = sample.position_variance
        if not math.isfinite(r_pos):
            r_pos = prm.vision_position_std**2
        x, p = self._update(x, p, 0, np.asarray(sample.position_ned, dtype=np.float64).tolist(),
                            r_pos)
        if sample.velocity_ned is not None:
            r_vel = sample.velocity_variance
            if not math.isfinite(r_vel):
                r_vel = prm.vision_velocity_std**2
            x, p = self._update(x, p, 1, np.asarray(sample.velocity_ned,
                                                    dtype=np.float64).tolist(), r_vel)
        entry.x, entry.p = x, p
        for k in range(index + 1, len(buffer)):
            later = buffer[k]
            x, p = self._propagate(x, p, later.u, later.dt_s)
            later.x, later.p = x, p
        self._x, self._p = x, p
        if sample.q is not None:
            q = np.asarray(sample.q, dtype=np.float64).tolist()
            self._correct_yaw(_fq_yaw((q[0], q[1], q[2], q[3])) - entry.yaw)
        self._last_vision_us = max(self._last_vision_us or 0, sample.sample_time_us)
        self._fused += 1
        return True

    @staticmethod
    def _update(
        x: _AxisStates, p: _AxisCovs, state: int, z: list[float], r: float
    ) -> tuple[_AxisStates, _AxisCovs]:
        """Scalar measurement of state ``state`` on every axis (variance ``r``):
        ``k = P[:, s] / (P[s, s] + r)``, ``x += k (z - x[s])``, ``P -= k P[s, :]``."""
        xs = []
        ps = []
        for i in range(3):
            p00, p01, p02, p11, p12, p22 = p[i]
            col = (p00, p01, p02) if state == 0 else (p01, p11, p12)  # P[:, s] = P[s, :]
            s = col[state] + r
            k0, k1, k2 = col[0] / s, col[1] / s, col[2] / s
            pos, vel, bias = x[i]
            innovation = z[i] - (pos if state == 0 else vel)
            xs.append((pos + k0 * innovation, vel + k1 * innovation, bias + k2 * innovation))
            c0, c1, c2 = col
            ps.append((p00 - k0 * c0, p01 - 0.5 * (k0 * c1 + k1 * c0),
                       p02 - 0.5 * (k0 * c2 + k2 * c0), p11 - k1 * c1,
                       p12 - 0.5 * (k1 * c2 + k2 * c1), p22 - k2 * c2))
        return (xs[0], xs[1], xs[2]), (ps[0], ps[1], ps[2])

    def _correct_yaw(self, innovation: float) -> None:
        """Turn the attitude about NED down by a fraction of the vision yaw innovation."""
        prm = self.params
        error = _wrap_pi(innovation)
        turn = _quat_from_rotation(0.0, 0.0, prm.yaw_correction_fraction * error)
        self._q = _fq_normalise(_fq_multiply(turn, self._q))
        down = _fq_dcm_row_z(self._q)
        k, lim = prm.yaw_bias_gain * error, prm.gyro_bias_limit
        bx, by, bz = self._gyro_bias
        self._gyro_bias = (min(max(bx - k * down[0], -lim), lim),
                           min(max(by - k * down[1], -lim), lim),
                           min(max(bz - k * down[2], -lim), lim))

    # --- output -----------------------------------------------------------------------------

    def output(self) -> EstimatorOutput:
        """The current estimate."""
        since = self._time_us - self._last_vision_us if self._last_vision_us is not None else None
        dead_reckoning = max(since, 0) if since is not None else self._time_us
        x, p = self._x, self._p
        return EstimatorOutput(
            time_us=self._time_us,
            state=VehicleState.from_unit((x[0][0], x[1][0], x[2][0]),
                                         (x[0][1], x[1][1], x[2][1]), self._q, self._rate),
            position_variance_ned=np.array((p[0][0], p[1][0], p[2][0])),
            velocity_variance_ned=np.array((p[0][3], p[1][3], p[2][3])),
            accel_bias_ned=np.array((x[0][2], x[1][2], x[2][2])),
            gyro_bias_frd=np.array(self._gyro_bias),
            position_valid=since is not None and since <= self.params.vision_timeout_us,
            dead_reckoning_time_us=dead_reckoning,
            vision_fused=self._fused,
            vision_rejected=self._rejected,
        )
