"""A small 6-DOF rigid-body quadrotor in pure numpy, to test the FCU modules on their own.

The real simulation is MuJoCo (:mod:`sim.scene`); this integrates the same
:class:`~sim.quadrotor.QuadrotorParams` with RK4 at 1 kHz: rotor thrusts through the
allocation matrix of :mod:`sim.quadrotor`, its first-order :class:`MotorModel`, gravity,
an optional linear drag and external force, and its :class:`ImuNoiseModel`. No ground,
no rotor aerodynamics beyond that. Frames as MuJoCo: world ENU, body FLU,
``q_enu_flu`` ``[w, x, y, z]``; :func:`vehicle_state_ned` and :func:`imu_frd` convert at
the FCU edge.

:func:`fly` is the closed loop used by the tests: body -> noisy IMU -> estimator (or
truth) -> cascade -> motors, with delayed 30 Hz vision poses.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.fcu.control import (
    Cascade,
    TrajectorySetpointData,
    VehicleState,
    quat_from_axis_angle,
    quat_multiply,
    quat_to_dcm,
)
from sim.fcu.estimator import Estimator, VisionSample
from sim.quadrotor import (
    GRAVITY,
    ImuNoiseModel,
    ImuNoiseParams,
    ImuSample,
    MotorModel,
    QuadrotorParams,
    allocation_matrix,
)

__all__ = [
    "FlightLog",
    "RigidBody",
    "RigidBodyState",
    "SetpointSource",
    "VisionModel",
    "fly",
    "imu_frd",
    "q_enu_flu_to_ned_frd",
    "vehicle_state_ned",
]

FloatArray = npt.NDArray[np.float64]
ForceFunction = Callable[[float], npt.ArrayLike]
SetpointSource = Callable[[int, VehicleState], TrajectorySetpointData]

_SQRT_HALF = math.sqrt(0.5)
_Q_NED_ENU = np.array([0.0, _SQRT_HALF, _SQRT_HALF, 0.0])  # pi about (1, 1, 0) / sqrt 2
_Q_FLU_FRD = np.array([0.0, 1.0, 0.0, 0.0])  # pi about x


def _enu_ned(v: FloatArray) -> FloatArray:
    """World vector ENU <-> NED: swap x and y, negate z (an involution)."""
    return np.array([v[1], v[0], -v[2]])


def _flu_frd(v: FloatArray) -> FloatArray:
    """Body vector FLU <-> FRD: negate y and z (an involution)."""
    return np.array([v[0], -v[1], -v[2]])


def q_enu_flu_to_ned_frd(q_enu_flu: FloatArray) -> FloatArray:
    """``q_ned_frd = q_ned_enu (x) q_enu_flu (x) q_flu_frd`` with ``w >= 0``."""
    q = quat_multiply(quat_multiply(_Q_NED_ENU, q_enu_flu), _Q_FLU_FRD)
    return -q if q[0] < 0.0 else q


@dataclass(frozen=True)
class RigidBodyState:
    """Ground truth (ENU world, FLU body)."""

    time_s: float
    position_enu: FloatArray  # m
    velocity_enu: FloatArray  # m/s
    q_enu_flu: FloatArray  # [w, x, y, z]
    angular_velocity_flu: FloatArray  # rad/s
    motor_thrusts: FloatArray  # N, actual (after the motor lag)


def vehicle_state_ned(state: RigidBodyState) -> VehicleState:
    """The truth as the FCU would see it (NED, FRD)."""
    return VehicleState(
        _enu_ned(state.position_enu),
        _enu_ned(state.velocity_enu),
        q_enu_flu_to_ned_frd(state.q_enu_flu),
        _flu_frd(state.angular_velocity_flu),
    )


def imu_frd(sample: ImuSample) -> ImuSample:
    """An FLU IMU sample expressed in FRD (PX4's sensor frame)."""
    return ImuSample(_flu_frd(sample.accel), _flu_frd(sample.gyro))


class RigidBody:
    """Quadrotor rigid body with motor lag, RK4-integrated; ENU/FLU.

    ``step(commanded_thrusts, dt_s)`` holds the commands over ``dt_s``; ``imu(dt_s)``
    reads the noisy accelerometer (specific force) and gyro at the current state. ``rng``
    becomes the IMU noise model's own (it draws ahead): give it a generator nothing else uses.
    """

    def __init__(
        self,
        params: QuadrotorParams | None = None,
        *,
        position_enu: npt.ArrayLike = (0.0, 0.0, 0.0),
        yaw_enu: float = 0.0,
        imu_noise: ImuNoiseParams | None = None,
        rng: np.random.Generator | None = None,
        linear_drag: float = 0.0,
        external_force_enu: ForceFunction | None = None,
    ) -> None:
        self.params = params if params is not None else QuadrotorParams()
        self._mass = self.params.mass
        self._inertia = np.array(self.params.inertia, dtype=np.float64)
        self._alloc = allocation_matrix(self.params)
        self._drag = linear_drag  # N per m/s
        self._force = external_force_enu
        self.motors = MotorModel.hovering(self.params)
        noise = imu_noise if imu_noise is not None else ImuNoiseParams()
        self._imu = ImuNoiseModel(noise, rng if rng is not None else np.random.default_rng(0))
        self._t = 0.0
        self._x = np.zeros(13)
        self._x[0:3] = np.asarray(position_enu, dtype=np.float64)
        self._x[6:10] = [math.cos(yaw_enu / 2.0), 0.0, 0.0, math.sin(yaw_enu / 2.0)]

    def _wrench(self, thrusts: FloatArray) -> tuple[float, FloatArray]:
        wrench = self._alloc @ thrusts
        return float(wrench[0]), wrench[1:]

    def _non_gravity_force_enu(self, x: FloatArray, collective: float, t: float) -> FloatArray:
        force = quat_to_dcm(x[6:10])[:, 2] * collective - self._drag * x[3:6]
        if self._force is not None:
            force = force + np.asarray(self._force(t), dtype=np.float64)
        return force

    def _derivative(
        self, x: FloatArray, collective: float, torque: FloatArray, t: float
    ) -> FloatArray:
        """d/dt of ``[p, v, q, w]``; written on floats (single-vector numpy is slow)."""
        _, _, _, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz = x.tolist()
        ix, iy, iz = self._inertia.tolist()
        tx, ty, tz = torque.tolist()
        n = 1.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
        body_z = (
            2.0 * (qx * qz + qw * qy) * n,
            2.0 * (qy * qz - qw * qx) * n,
            1.0 - 2.0 * (qx * qx + qy * qy) * n,
        )
        fx = body_z[0] * collective - self._drag * vx
        fy = body_z[1] * collective - self._drag * vy
        fz = body_z[2] * collective - self._drag * vz
        if self._force is not None:
            ex, ey, ez = np.asarray(self._force(t), dtype=np.float64).tolist()
            fx, fy, fz = fx + ex, fy + ey, fz + ez
        m = self._mass
        return np.array(
            [
                vx, vy, vz,
                fx / m, fy / m, fz / m - GRAVITY,
                0.5 * (-qx * wx - qy * wy - qz * wz),
                0.5 * (qw * wx + qy * wz - qz * wy),
                0.5 * (qw * wy - qx * wz + qz * wx),
                0.5 * (qw * wz + qx * wy - qy * wx),
                (tx - (wy * iz * wz - wz * iy * wy)) / ix,
                (ty - (wz * ix * wx - wx * iz * wz)) / iy,
                (tz - (wx * iy * wy - wy * ix * wx)) / iz,
            ]
        )  # fmt: skip

    def step(self, commanded_thrusts: npt.ArrayLike, dt_s: float) -> None:
        """Advance ``dt_s`` seconds; thrust is the motor output averaged over the step."""
        before = self.motors.thrust
        after = self.motors.step(commanded_thrusts, dt_s)
        collective, torque = self._wrench(0.5 * (before + after))
        x, t, h = self._x, self._t, dt_s
        k1 = self._derivative(x, collective, torque, t)
        k2 = self._derivative(x + 0.5 * h * k1, collective, torque, t + 0.5 * h)
        k3 = self._derivative(x + 0.5 * h * k2, collective, torque, t + 0.5 * h)
        k4 = self._derivative(x + h * k3, collective, torque, t + h)
        x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        x[6:10] /= math.sqrt(float(x[6:10] @ x[6:10]))
        self._x, self._t = x, t + h

    @property
    def state(self) -> RigidBodyState:
        """Ground truth now (copies)."""
        x = self._x
        return RigidBodyState(
            self._t,
            x[0:3].copy(),
            x[3:6].copy(),
            x[6:10].copy(),
            x[10:13].copy(),
            self.motors.thrust,
        )

    def imu(self, dt_s: float) -> ImuSample:
        """Noisy IMU (FLU) at the current state; ``dt_s`` is the sample period."""
        collective, _ = self._wrench(self.motors.thrust)
        force = self._non_gravity_force_enu(self._x, collective, self._t)
        specific_force = quat_to_dcm(self._x[6:10]).T @ force / self._mass
        return self._imu.sample(specific_force, self._x[10:13], dt_s)

    def rotate(self, rotation_vector_flu: npt.ArrayLike) -> None:
        """Turn the body by a rotation vector [rad, FLU] (to set up tests)."""
        turn = quat_from_axis_angle(np.asarray(rotation_vector_flu, dtype=np.float64))
        self._x[6:10] = quat_multiply(self._x[6:10], turn)


@dataclass(frozen=True)
class VisionModel:
    """External-vision poses: sampled at ``rate_hz`` from the truth with Gaussian noise,
    delivered ``latency_us`` later (as on ``/fmu/in/vehicle_visual_odometry``)."""

    rate_hz: float = 30.0
    position_std: float = 0.01  # m
    yaw_std: float = 0.005  # rad
    latency_us: int = 0
    seed: int = 0


@dataclass(frozen=True)
class FlightLog:
    """One row per control tick (NED, FRD)."""

    time_us: npt.NDArray[np.int64]
    true_position_ned: FloatArray
    true_velocity_ned: FloatArray
    true_q: FloatArray
    estimated_position_ned: FloatArray
    estimated_velocity_ned: FloatArray
    estimated_q: FloatArray
    setpoint_position_ned: FloatArray
    motor_thrusts: FloatArray
    saturated: npt.NDArray[np.bool_]


def fly(
    body: RigidBody,
    cascade: Cascade,
    setpoints: SetpointSource,
    duration_us: int,
    *,
    estimator: Estimator | None = None,
    vision: VisionModel | None = None,
    control_period_us: int = 2_000,
    physics_steps: int = 2,
) -> FlightLog:
    """Fly ``duration_us`` of FCU time; the FCU clock starts at 0 with the body's time.

    Each control tick: read the IMU, propagate the estimator, deliver the vision samples
    that have arrived, run the cascade on the estimate (the truth when ``estimator`` is
    None), then integrate ``physics_steps`` physics steps under the motor commands.
    """
    if duration_us <= 0 or control_period_us <= 0 or physics_steps <= 0:
        raise ValueError("duration_us, control_period_us and physics_steps must be > 0")
    vision = vision if vision is not None else VisionModel()
    rng = np.random.default_rng(vision.seed)
    vision_period_us = round(1_000_000 / vision.rate_hz)
    next_vision_us = 0
    in_flight: list[tuple[int, VisionSample]] = []
    dt_s = control_period_us / 1_000_000
    ticks = duration_us // control_period_us
    rows: dict[str, list[FloatArray]] = {name: [] for name in FlightLog.__dataclass_fields__}
    for tick in range(ticks):
        now_us = tick * control_period_us
        truth = vehicle_state_ned(body.state)
        if estimator is not None:
            if tick > 0:
                imu = imu_frd(body.imu(dt_s))
                estimator.predict(now_us, imu.accel, imu.gyro)
            while next_vision_us <= now_us:
                yaw_noise = rng.normal(0.0, vision.yaw_std)
                turn = np.array([math.cos(yaw_noise / 2.0), 0.0, 0.0, math.sin(yaw_noise / 2.0)])
                sample = VisionSample(
                    sample_time_us=now_us,
                    position_ned=truth.position_ned + rng.normal(0.0, vision.position_std, 3),
                    q=quat_multiply(turn, truth.q),
                    position_variance=vision.position_std**2,
                )
                in_flight.append((now_us + vision.latency_us, sample))
                next_vision_us += vision_period_us
            while in_flight and in_flight[0][0] <= now_us:
                estimator.fuse_vision(in_flight.pop(0)[1])
            state = estimator.output().state
        else:
            state = truth
        setpoint = setpoints(now_us, state)
        out = cascade.update(state, setpoint, control_period_us)
        for _ in range(physics_steps):
            body.step(out.motor_thrusts, dt_s / physics_steps)
        rows["time_us"].append(np.array(now_us))
        rows["true_position_ned"].append(truth.position_ned)
        rows["true_velocity_ned"].append(truth.velocity_ned)
        rows["true_q"].append(truth.q)
        rows["estimated_position_ned"].append(state.position_ned)
        rows["estimated_velocity_ned"].append(state.velocity_ned)
        rows["estimated_q"].append(state.q)
        rows["setpoint_position_ned"].append(setpoint.position)
        rows["motor_thrusts"].append(out.motor_thrusts)
        rows["saturated"].append(np.array(out.saturated))
    arrays = {name: np.array(values, dtype=np.float64) for name, values in rows.items()}
    return FlightLog(
        time_us=np.array(rows["time_us"], dtype=np.int64),
        true_position_ned=arrays["true_position_ned"],
        true_velocity_ned=arrays["true_velocity_ned"],
        true_q=arrays["true_q"],
        estimated_position_ned=arrays["estimated_position_ned"],
        estimated_velocity_ned=arrays["estimated_velocity_ned"],
        estimated_q=arrays["estimated_q"],
        setpoint_position_ned=arrays["setpoint_position_ned"],
        motor_thrusts=arrays["motor_thrusts"],
        saturated=np.array(rows["saturated"], dtype=bool),
    )
