"""State estimator of the simulated FCU: attitude filter + delayed-fusion position filter.

Pure numpy and numba (:mod:`sim.fcu.kernels`); frames as on the FCU (world NED, body
FRD, ``q_ned_frd`` Hamilton ``[w, x, y, z]``); time is the FCU clock in integer microseconds.

* Attitude: gyro integration with a gyro-bias estimate (a Mahony filter's structure);
  external-vision yaw corrects the heading. Aided, roll and pitch are corrected by the
  tilt error the horizontal position filter estimates, which also teaches the gyro bias;
  unaided (before the first vision sample, and after ``noaid_timeout_us`` of dead
  reckoning) the accelerometer pulls them towards gravity while the specific force is
  within ``accel_gate`` of 1 g.
* Horizontal position and velocity: one Kalman filter with state ``[north, east, v north,
  v east, tilt error north, east, accelerometer bias x, y]``. The tilt error (the
  horizontal specific force a wrong roll or pitch adds, fixed in the world) and the
  accelerometer's bias (fixed in the body) make the same error at one heading: the
  filter tells them apart by the turns (the bias turns with the vehicle, the tilt error
  does not), as EKF2 does with its delta-velocity bias. The tilt is fed back continuously
  into the attitude (``accel_correction_gain``), leaving the filter's state as a known
  input; the bias stays a state of the filter. Before, a tilt error cancelled the bias in
  aided flight and turned against it in dead reckoning: a turn without vision accelerated
  the vehicle at the bias.
* Vertical: a Kalman filter ``[down, v down, acceleration bias down]``.
* Both are driven by the specific force rotated to NED with gravity removed (the bias is
  in their models), and fuse external-vision position (and velocity, when given); a
  sample that starts the fusion resets the position to it.
* Delay: like EKF2's buffers, a bounded history (``buffer_length_us``) of (time, filter
  state, covariance, IMU input) is kept. A vision sample is fused at its own sample time:
  the filter rewinds to the buffered state at that time, updates, and re-propagates the
  stored IMU inputs to now. ``fuse_at_arrival=True`` ignores the sample time (the naive
  estimator, for comparison). The heading correction uses the yaw buffered at the
  sample time the same way.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters
from sim.fcu.control import Quat, Vec3, VehicleState, _fq_normalise, _fq_yaw
from sim.fcu.kernels import (
    ATTITUDE_AIDED,
    ATTITUDE_GRAVITY,
    ATTITUDE_GYRO,
    EST_BUF_COLS,
    EST_GYRO_BIAS,
    EST_H,
    EST_HP,
    EST_OUTPUT_INDEX,
    EST_PARAMS_SIZE,
    EST_Q,
    EST_RATE,
    EST_STATE_SIZE,
    EST_V,
    EST_VP,
    est_fuse,
    est_predict,
    est_push,
)

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
    gyro_bias_gain: float = param(unit="1/s^2", range=(0.0, 10.0))
    gyro_bias_limit: float = param(unit="rad/s", range=(0.0, 1.0))
    yaw_correction_fraction: float = param(unit="per vision sample", range=(0.0, 1.0))
    yaw_bias_gain: float = param(unit="1/s per vision sample", range=(0.0, 10.0))
    accel_noise: float = param(unit="m/s^2/sqrt(Hz)", range=(1e-4, 100.0))
    accel_bias_noise: float = param(unit="m/s^3/sqrt(Hz)", range=(0.0, 10.0))
    body_accel_bias_noise: float = param(unit="m/s^3/sqrt(Hz)", range=(0.0, 10.0))
    tilt_noise: float = param(unit="m/s^3/sqrt(Hz)", range=(0.0, 10.0))
    vision_position_std: float = param(unit="m", range=(1e-4, 100.0))
    vision_velocity_std: float = param(unit="m/s", range=(1e-4, 100.0))
    initial_position_std: float = param(unit="m", range=(1e-3, 1000.0))
    initial_velocity_std: float = param(unit="m/s", range=(1e-3, 100.0))
    initial_accel_bias_std: float = param(unit="m/s^2", range=(0.0, 10.0))
    initial_tilt_std: float = param(unit="m/s^2", range=(0.0, 10.0))
    buffer_length_us: int = param(unit="us", range=(1_000, 10_000_000))
    vision_timeout_us: int = param(unit="us", range=(1_000, 100_000_000))
    noaid_timeout_us: int = param(unit="us", range=(1_000, 100_000_000))

    def __post_init__(self) -> None:
        validate_parameters(self)
        if self.noaid_timeout_us < self.vision_timeout_us:
            raise ParameterError(
                f"{self.noaid_timeout_us!r} is outside the allowed range "
                f"[vision_timeout_us = {self.vision_timeout_us!r}, 100000000] us",
                key="noaid_timeout_us")


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


class EstimatorOutput(NamedTuple):
    """The estimate at ``time_us``, its variances and health flags (a named tuple: built up
    to every main-loop tick, in one call)."""

    time_us: int
    state: VehicleState
    position_variance_ned: FloatArray  # m^2
    velocity_variance_ned: FloatArray  # (m/s)^2
    accel_bias_frd: FloatArray  # m/s^2: x, y the body's; z the vertical filter's (down)
    gyro_bias_frd: FloatArray  # rad/s
    position_valid: bool  # vision fused within vision_timeout_us
    dead_reckoning_time_us: int  # since the last fused vision sample (0 right after one)
    vision_fused: int  # count of fused samples
    vision_rejected: int  # count of samples older than the buffer


_INITIAL_BUFFER_ROWS = 64  # grows by doubling when full


class Estimator:
    """Attitude filter + horizontal (tilt and body-bias) and vertical Kalman filters.

    Feed IMU samples with :meth:`predict` (body FRD specific force and rate) and vision
    samples with :meth:`fuse_vision`; read :meth:`output`. The arithmetic runs in
    :mod:`sim.fcu.kernels` (compiled) on a state array and a ring buffer of past states.
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
        self._prm = np.array([
            params.accel_correction_gain, params.accel_gate, params.tilt_noise**2,
            params.gyro_bias_gain, params.gyro_bias_limit, params.yaw_correction_fraction,
            params.yaw_bias_gain, params.accel_noise**2, params.accel_bias_noise**2,
            params.body_accel_bias_noise**2], dtype=np.float64)
        assert self._prm.shape == (EST_PARAMS_SIZE,)
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
        n, e, d = np.asarray(position_ned, dtype=np.float64).reshape(3).tolist()
        s = np.zeros(EST_STATE_SIZE)
        s[EST_Q:EST_Q + 4] = _fq_normalise((q_list[0], q_list[1], q_list[2], q_list[3]))
        s[EST_H:EST_H + 2] = (n, e)
        s[EST_V] = d
        s[EST_HP:EST_HP + 64] = np.diag(np.repeat(
            [prm.initial_position_std**2, prm.initial_velocity_std**2,
             prm.initial_tilt_std**2, prm.initial_accel_bias_std**2], 2)).ravel()
        s[EST_VP:EST_VP + 6] = (prm.initial_position_std**2, 0.0, 0.0,
                                prm.initial_velocity_std**2, 0.0, prm.initial_accel_bias_std**2)
        self._s = s
        self._last_vision_us: int | None = None
        self._fused = 0
        self._rejected = 0
        self._buf = np.zeros((_INITIAL_BUFFER_ROWS, EST_BUF_COLS))
        self._meta = np.zeros(2, dtype=np.int64)  # ring head, count
        self._restart_buffer()

    def _grow(self) -> None:
        head, count = int(self._meta[0]), int(self._meta[1])
        buf = self._buf
        rows = (head + np.arange(count)) % buf.shape[0]
        grown = np.zeros((2 * buf.shape[0], EST_BUF_COLS))
        grown[:count] = buf[rows]
        self._buf = grown
        self._meta[0] = 0
        self._buffer_full = False

    # --- prediction -----------------------------------------------------------------------

    def predict(self, time_us: int, accel_frd: Sequence[float] | FloatArray,
                gyro_frd: Sequence[float] | FloatArray) -> None:
        """Propagate to ``time_us`` with an IMU sample (specific force m/s^2, rate rad/s, FRD)."""
        if time_us <= self._time_us:
            raise ValueError(f"time_us: {time_us} is not after the last sample ({self._time_us})")
        dt = (time_us - self._time_us) / _US_PER_S
        self._time_us = time_us
        ax, ay, az = map(float, accel_frd)
        gx, gy, gz = map(float, gyro_frd)
        if self._buffer_full:
            self._grow()
        self._buffer_full = est_predict(
            self._s, self._buf, self._meta, self._prm, float(time_us), dt, ax, ay, az, gx, gy,
            gz, self._attitude_mode(), float(time_us - self.params.buffer_length_us))

    def _attitude_mode(self) -> int:
        """The attitude filter's reference: the position filter's tilt error while vision
        comes (within ``vision_timeout_us``); the gyro, and the tilt error and bias the
        filter last knew, while dead reckoning (up to ``noaid_timeout_us``,
        EKF2_NOAID_TOUT); gravity before the first vision sample and after the dead
        reckoning (levelling, as EKF2's fake-position fusion does then).

        Not gravity at once: a multicopter's accelerometer measures the thrust, along the
        body's z, not gravity, so "the specific force is vertical" levels the estimate
        with the body whatever its true tilt. Holding a position on the dead-reckoned
        estimate needs the tilt the hold put in; a gravity reference would take it out of
        the estimate as fast as the controller puts it in, and the true tilt would run away
        (about 0.5 deg/s: metres off within seconds).
        """
        last = self._last_vision_us
        if last is None:
            return ATTITUDE_GRAVITY
        since = self._time_us - last
        if since <= self.params.vision_timeout_us:
            return ATTITUDE_AIDED
        return ATTITUDE_GYRO if since <= self.params.noaid_timeout_us else ATTITUDE_GRAVITY

    def set_gyro_bias(self, bias_frd: Sequence[float]) -> None:
        """Set the gyro-bias estimate [rad/s, FRD] (the firmware's at-rest calibration),
        clamped to ``gyro_bias_limit``."""
        lim = self.params.gyro_bias_limit
        for i, b in enumerate(bias_frd):
            self._s[EST_GYRO_BIAS + i] = min(max(float(b), -lim), lim)

    def position_valid(self) -> bool:
        """Vision fused within ``vision_timeout_us`` (the filter is aided; what
        :meth:`output` gives as ``position_valid``)."""
        last = self._last_vision_us
        return last is not None and self._time_us - last <= self.params.vision_timeout_us

    # --- vision fusion ----------------------------------------------------------------------

    def fuse_vision(self, sample: VisionSample) -> bool:
        """Fuse an external-vision sample; False when it is older than the buffer.

        A sample that starts the fusion (the first, or the first after
        ``vision_timeout_us`` without one) resets the position to it, as EKF2 resets to
        external vision when its fusion (re)starts. The filter boots at the origin, metres
        from where the vehicle stands, and pulling the estimate there through the filter
        would make a transient acceleration that the tilt and bias states learn (on a pad
        18 m from the origin: 0.4 m/s^2 of bias, 2 deg of tilt that no turn corrects);
        after an outage, the dead-reckoned drift would do the same."""
        prm = self.params
        r_pos = sample.position_variance
        if not math.isfinite(r_pos):
            r_pos = prm.vision_position_std**2
        last = self._last_vision_us
        starts = last is None or sample.sample_time_us - last > prm.vision_timeout_us
        in_buffer = self.fuse_at_arrival or sample.sample_time_us >= self._buf[
            int(self._meta[0]), 0]
        if starts and in_buffer:
            self._reset_position(sample.position_ned, r_pos, boot=last is None)
            self._last_vision_us = max(last or 0, sample.sample_time_us)
            self._fused += 1
            return True
        z0, z1, z2 = map(float, sample.position_ned)
        has_velocity = sample.velocity_ned is not None
        v0 = v1 = v2 = r_vel = 0.0
        if sample.velocity_ned is not None:
            v0, v1, v2 = map(float, sample.velocity_ned)
            r_vel = sample.velocity_variance
            if not math.isfinite(r_vel):
                r_vel = prm.vision_velocity_std**2
        sample_yaw = 0.0
        if sample.q is not None:
            qw, qx, qy, qz = map(float, sample.q)
            sample_yaw = _fq_yaw((qw, qx, qy, qz))
        fused = est_fuse(self._s, self._buf, self._meta, self._prm,
                         float(sample.sample_time_us), self.fuse_at_arrival, z0, z1, z2,
                         float(r_pos), has_velocity, v0, v1, v2, float(r_vel),
                         sample.q is not None, sample_yaw)
        if not fused:
            self._rejected += 1
            return False
        self._last_vision_us = max(self._last_vision_us or 0, sample.sample_time_us)
        self._fused += 1
        return True

    def _reset_position(self, position_ned: npt.ArrayLike, variance: float, *,
                        boot: bool) -> None:
        """Position to ``position_ned`` [m] with ``variance`` [m^2], its cross terms
        cleared; tilt and bias as they are. At ``boot`` (the first sample) the velocity
        too, to zero with its initial variance; after an outage the dead-reckoned velocity
        is kept. The buffered history restarts from now (a replay must not bring the old
        position back)."""
        n, e, d = np.asarray(position_ned, dtype=np.float64).reshape(3).tolist()
        s = self._s
        hp = s[EST_HP:EST_HP + 64].reshape(8, 8)  # a view
        s[EST_H:EST_H + 2] = (n, e)
        s[EST_V] = d
        reset = 4 if boot else 2  # the horizontal states reset: position (and velocity)
        hp[:reset, :] = 0.0
        hp[:, :reset] = 0.0
        hp[0, 0] = hp[1, 1] = variance
        vp = s[EST_VP:EST_VP + 6]  # a view: p00 p01 p02 p11 p12 p22
        vp[0], vp[1], vp[2] = variance, 0.0, 0.0
        if boot:
            s[EST_H + 2:EST_H + 4] = (0.0, 0.0)
            s[EST_V + 1] = 0.0
            hp[2, 2] = hp[3, 3] = self.params.initial_velocity_std**2
            vp[3], vp[4] = self.params.initial_velocity_std**2, 0.0
        self._restart_buffer()

    def _restart_buffer(self) -> None:
        """The delayed-fusion history: the current state alone, at the current time."""
        self._meta[:] = 0
        est_push(self._buf, self._meta, self._s, float(self._time_us), 0.0, 0.0, 0.0, 0.0,
                 1.0, 0.0, np.zeros(2), -math.inf)
        self._buffer_full = False  # (the ring starts with room for more than one entry)

    # --- output -----------------------------------------------------------------------------

    def attitude(self) -> Quat:
        """The current ``q_ned_frd`` as floats (what :meth:`output` would give as
        ``state.q``), without building the output."""
        w, x, y, z = self._s[EST_Q:EST_Q + 4].tolist()
        return (w, x, y, z)

    def kinematics(self) -> tuple[Vec3, Vec3, Quat, Vec3]:
        """The current position and velocity [NED], ``q_ned_frd`` and angular velocity
        [FRD] as floats (what :meth:`output` would give in ``state``), without building the
        output."""
        s = self._s.tolist()
        n, e, vn, ve = s[EST_H:EST_H + 4]
        d, vd = s[EST_V:EST_V + 2]
        w, x, y, z = s[EST_Q:EST_Q + 4]
        p, q, r = s[EST_RATE:EST_RATE + 3]
        return (n, e, d), (vn, ve, vd), (w, x, y, z), (p, q, r)

    def eph(self) -> float:
        """Horizontal position accuracy [m]: the larger north/east standard deviation (what
        the firmware publishes as ``vehicle_local_position.eph``)."""
        return math.sqrt(max(float(self._s[EST_HP]), float(self._s[EST_HP + 9])))

    def output(self) -> EstimatorOutput:
        """The current estimate."""
        since = self._time_us - self._last_vision_us if self._last_vision_us is not None else None
        dead_reckoning = max(since, 0) if since is not None else self._time_us
        out = self._s[EST_OUTPUT_INDEX]  # a copy
        out.setflags(write=False)  # the views below are read-only too
        return EstimatorOutput(
            time_us=self._time_us,
            state=VehicleState.from_unit_arrays(out[0:3], out[3:6], out[6:10], out[10:13]),
            position_variance_ned=out[13:16],
            velocity_variance_ned=out[16:19],
            accel_bias_frd=out[19:22],
            gyro_bias_frd=out[22:25],
            position_valid=self.position_valid(),
            dead_reckoning_time_us=dead_reckoning,
            vision_fused=self._fused,
            vision_rejected=self._rejected,
        )
