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
    VehicleState,
    cross3,
    quat_from_axis_angle,
    quat_multiply,
    quat_to_dcm,
    quat_yaw,
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
_GRAVITY_NED = np.array([0.0, 0.0, GRAVITY])


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
    x: FloatArray  # (3 axes, [p, v, b])
    p: FloatArray  # (3 axes, 3, 3)
    u: FloatArray  # NED acceleration input over the step [m/s^2]
    dt_s: float
    yaw: float  # attitude filter yaw at time_us [rad]


def _wrap_pi(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class Estimator:
    """Attitude complementary filter + per-axis position/velocity Kalman filters.

    Feed IMU samples with :meth:`predict` (body FRD specific force and rate) and vision
    samples with :meth:`fuse_vision`; read :meth:`output`.
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
        q_arr = np.asarray(q, dtype=np.float64).reshape(4)
        self._q = q_arr / math.sqrt(float(q_arr @ q_arr))
        self._gyro_bias = np.zeros(3)
        self._rate = np.zeros(3)
        self._x = np.zeros((3, 3))
        self._x[:, 0] = np.asarray(position_ned, dtype=np.float64).reshape(3)
        p0 = np.diag(
            [
                prm.initial_position_std**2,
                prm.initial_velocity_std**2,
                prm.initial_accel_bias_std**2,
            ]
        )
        self._p = np.repeat(p0[None, :, :], 3, axis=0)
        self._last_vision_us: int | None = None
        self._fused = 0
        self._rejected = 0
        self._buffer: deque[_Entry] = deque()
        self._buffer.append(
            _Entry(time_us, self._x.copy(), self._p.copy(), np.zeros(3), 0.0, quat_yaw(self._q))
        )

    # --- prediction -----------------------------------------------------------------------

    def predict(self, time_us: int, accel_frd: npt.ArrayLike, gyro_frd: npt.ArrayLike) -> None:
        """Propagate to ``time_us`` with an IMU sample (specific force m/s^2, rate rad/s, FRD)."""
        if time_us <= self._time_us:
            raise ValueError(f"time_us: {time_us} is not after the last sample ({self._time_us})")
        dt = (time_us - self._time_us) / _US_PER_S
        self._time_us = time_us
        accel = np.asarray(accel_frd, dtype=np.float64)
        gyro = np.asarray(gyro_frd, dtype=np.float64)
        self._propagate_attitude(accel, gyro, dt)
        u = quat_to_dcm(self._q) @ accel + _GRAVITY_NED
        self._x, self._p = self._propagate(self._x, self._p, u, dt)
        self._buffer.append(
            _Entry(time_us, self._x.copy(), self._p.copy(), u, dt, quat_yaw(self._q))
        )
        horizon = time_us - self.params.buffer_length_us
        while len(self._buffer) > 1 and self._buffer[1].time_us <= horizon:
            self._buffer.popleft()

    def _propagate_attitude(self, accel: FloatArray, gyro: FloatArray, dt: float) -> None:
        """Mahony step. The accelerometer's reference is the specific force the position
        filter believes in, ``R f - b`` (gravity plus the vehicle's own acceleration,
        ``motion_compensation`` of it): a tilt error shows up there as a horizontal
        acceleration bias, which vision makes observable."""
        prm = self.params
        rate = gyro - self._gyro_bias
        self._rate = rate
        norm = math.sqrt(float(accel @ accel))
        if prm.accel_correction_gain > 0.0 and abs(norm - GRAVITY) < prm.accel_gate:
            r = quat_to_dcm(self._q)
            reference_ned = r @ accel - self._x[:, 2]
            # without vision the filter's acceleration is not observable: trust gravity
            weight = prm.motion_compensation if self._aided() else 0.0
            reference_ned = weight * reference_ned + (1.0 - weight) * np.array(
                [0.0, 0.0, -GRAVITY]
            )
            predicted = r.T @ reference_ned
            predicted /= math.sqrt(float(predicted @ predicted))
            error = cross3(accel / norm, predicted)
            rate = rate + prm.accel_correction_gain * error
            bias = self._gyro_bias - prm.gyro_bias_gain * error * dt
            self._gyro_bias = np.clip(bias, -prm.gyro_bias_limit, prm.gyro_bias_limit)
        q = quat_multiply(self._q, quat_from_axis_angle(rate * dt))
        self._q = q / math.sqrt(float(q @ q))

    def _aided(self) -> bool:
        """Vision fused within ``vision_timeout_us``."""
        last = self._last_vision_us
        return last is not None and self._time_us - last <= self.params.vision_timeout_us

    def _propagate(
        self, x: FloatArray, p: FloatArray, u: FloatArray, dt: float
    ) -> tuple[FloatArray, FloatArray]:
        """One Kalman prediction of every axis over ``dt`` [s] with NED acceleration ``u``."""
        f = np.array([[1.0, dt, -0.5 * dt * dt], [0.0, 1.0, -dt], [0.0, 0.0, 1.0]])
        x_new = x @ f.T
        x_new[:, 0] += 0.5 * dt * dt * u
        x_new[:, 1] += dt * u
        qa = self.params.accel_noise**2
        qb = self.params.accel_bias_noise**2
        q = np.array(
            [
                [qa * dt**3 / 3.0, qa * dt * dt / 2.0, 0.0],
                [qa * dt * dt / 2.0, qa * dt, 0.0],
                [0.0, 0.0, qb * dt],
            ]
        )
        p_new = f @ p @ f.T + q
        return x_new, p_new

    # --- vision fusion ----------------------------------------------------------------------

    def fuse_vision(self, sample: VisionSample) -> bool:
        """Fuse an external-vision sample; False when it is older than the buffer."""
        prm = self.params
        if self.fuse_at_arrival or sample.sample_time_us >= self._buffer[-1].time_us:
            index = len(self._buffer) - 1
        else:
            times = [entry.time_us for entry in self._buffer]
            index = bisect.bisect_right(times, sample.sample_time_us) - 1
            if index < 0:
                self._rejected += 1
                return False
        entry = self._buffer[index]
        x, p = entry.x.copy(), entry.p.copy()
        r_pos = sample.position_variance
        if not math.isfinite(r_pos):
            r_pos = prm.vision_position_std**2
        x, p = self._update(x, p, 0, np.asarray(sample.position_ned, dtype=np.float64), r_pos)
        if sample.velocity_ned is not None:
            r_vel = sample.velocity_variance
            if not math.isfinite(r_vel):
                r_vel = prm.vision_velocity_std**2
            x, p = self._update(x, p, 1, np.asarray(sample.velocity_ned, dtype=np.float64), r_vel)
        entry.x, entry.p = x.copy(), p.copy()
        for later in list(self._buffer)[index + 1 :]:
            x, p = self._propagate(x, p, later.u, later.dt_s)
            later.x, later.p = x.copy(), p.copy()
        self._x, self._p = x, p
        if sample.q is not None:
            self._correct_yaw(quat_yaw(np.asarray(sample.q, dtype=np.float64)) - entry.yaw)
        self._last_vision_us = max(self._last_vision_us or 0, sample.sample_time_us)
        self._fused += 1
        return True

    @staticmethod
    def _update(
        x: FloatArray, p: FloatArray, state: int, z: FloatArray, r: float
    ) -> tuple[FloatArray, FloatArray]:
        """Scalar measurement of state ``state`` on every axis (variance ``r``)."""
        s = p[:, state, state] + r
        k = p[:, :, state] / s[:, None]
        x = x + k * (z - x[:, state])[:, None]
        p = p - k[:, :, None] * p[:, state, :][:, None, :]
        return x, 0.5 * (p + p.transpose(0, 2, 1))

    def _correct_yaw(self, innovation: float) -> None:
        """Turn the attitude about NED down by a fraction of the vision yaw innovation."""
        prm = self.params
        error = _wrap_pi(innovation)
        turn = quat_from_axis_angle(np.array([0.0, 0.0, prm.yaw_correction_fraction * error]))
        q = quat_multiply(turn, self._q)
        self._q = q / math.sqrt(float(q @ q))
        down_in_body = quat_to_dcm(self._q)[2, :]
        bias = self._gyro_bias - prm.yaw_bias_gain * error * down_in_body
        self._gyro_bias = np.clip(bias, -prm.gyro_bias_limit, prm.gyro_bias_limit)

    # --- output -----------------------------------------------------------------------------

    def output(self) -> EstimatorOutput:
        """The current estimate."""
        since = self._time_us - self._last_vision_us if self._last_vision_us is not None else None
        dead_reckoning = max(since, 0) if since is not None else self._time_us
        return EstimatorOutput(
            time_us=self._time_us,
            state=VehicleState(self._x[:, 0], self._x[:, 1], self._q, self._rate),
            position_variance_ned=self._p[:, 0, 0].copy(),
            velocity_variance_ned=self._p[:, 1, 1].copy(),
            accel_bias_ned=self._x[:, 2].copy(),
            gyro_bias_frd=self._gyro_bias.copy(),
            position_valid=since is not None and since <= self.params.vision_timeout_us,
            dead_reckoning_time_us=dead_reckoning,
            vision_fused=self._fused,
            vision_rejected=self._rejected,
        )
