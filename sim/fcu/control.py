"""PX4-style multicopter control cascade of the simulated FCU (pure numpy).

Position -> velocity -> acceleration (``PositionControl``), acceleration + yaw -> attitude
setpoint and collective thrust (``ControlMath::bodyzToAttitude``), quaternion attitude P
control with de-prioritised yaw (``AttitudeControl``), body-rate PID (``RateControl``) and
a quad-X mixer with PX4's airmode-off sequential desaturation
(``ControlAllocationSequentialDesaturation``).

Frames as on the FCU: world NED, body FRD, quaternions Hamilton ``[w, x, y, z]`` rotating
body FRD into world NED (``VehicleAttitude.q``). The mixer of :mod:`sim.quadrotor` works
in body FLU, so torques are converted at that one edge. Physical units throughout (N,
N m, m/s^2) instead of PX4's normalised thrust and torque: the controller knows the
vehicle's mass and inertia (PX4 learns the hover thrust instead).

Time: every ``update`` takes ``dt_us``, the elapsed FCU time in integer microseconds.

The small quaternion helpers below are single-vector fast paths for the control and
estimation loops; :mod:`flight_control.frames` holds the general, broadcasting versions
for the companion side (``sim`` sits below ``flight_control`` and does not import it).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from runtime.errors import ParameterError
from runtime.parameters import param, validate_parameters
from sim.fcu.kernels import (
    ATT_GAINS_SIZE,
    RATE_GAINS_SIZE,
    RATE_STATE_SIZE,
    attitude_kernel,
    mix_kernel,
    rate_kernel,
)
from sim.quadrotor import GRAVITY, NUM_ROTORS, QuadrotorParams, mix

__all__ = [
    "CONTROL_NODE_NAME",
    "AttitudeController",
    "Cascade",
    "CascadeOutput",
    "ControlGains",
    "InvalidSetpointError",
    "Mixer",
    "MixerOutput",
    "PositionControlOutput",
    "PositionController",
    "RateController",
    "TrajectorySetpointData",
    "VehicleState",
    "attitude_from_thrust_vector",
    "cross3",
    "mix_with_desaturation",
    "quat_from_axis_angle",
    "quat_from_dcm",
    "quat_multiply",
    "quat_to_dcm",
    "quat_yaw",
]

FloatArray = npt.NDArray[np.float64]
CONTROL_NODE_NAME = "fcu_control"
_US_PER_S = 1_000_000
_EPS = 1e-9


class InvalidSetpointError(ValueError):
    """A trajectory setpoint the position controller cannot follow (PX4 ``_inputValid``)."""


# --- quaternions [w, x, y, z], Hamilton; q_a_b rotates frame-b vectors into frame a -------


def cross3(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a x b`` for two 3-vectors (np.cross is slow on single vectors)."""
    ax, ay, az = a.tolist()
    bx, by, bz = b.tolist()
    return np.array([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx])


def quat_multiply(p: FloatArray, q: FloatArray) -> FloatArray:
    """Hamilton product ``p (x) q`` of two quaternions of shape (4,)."""
    pw, px, py, pz = p.tolist()
    qw, qx, qy, qz = q.tolist()
    return np.array(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ]
    )


def quat_to_dcm(q: FloatArray) -> FloatArray:
    """Rotation matrix ``R_a_b`` of ``q_a_b`` (normalised first)."""
    w, x, y, z = (q / math.sqrt(float(q @ q))).tolist()
    return np.array(
        [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
            [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
            [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
        ]
    )


def quat_from_dcm(r: FloatArray) -> FloatArray:
    """Unit quaternion (``w >= 0``) of a rotation matrix (Shepperd's method)."""
    trace = float(r[0, 0] + r[1, 1] + r[2, 2])
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = [(r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s]
    out = np.array(q, dtype=np.float64)
    out /= math.sqrt(float(out @ out))
    return -out if out[0] < 0.0 else out


def quat_from_axis_angle(rotation_vector: FloatArray) -> FloatArray:
    """Quaternion of the rotation by ``|v|`` rad about ``v / |v|`` (exponential map)."""
    angle = math.sqrt(float(rotation_vector @ rotation_vector))
    if angle < 1e-12:
        return np.array([1.0, *(0.5 * rotation_vector).tolist()])
    half = 0.5 * angle
    return np.array([math.cos(half), *(math.sin(half) / angle * rotation_vector).tolist()])


def quat_yaw(q: FloatArray) -> float:
    """Euler yaw [rad] (Z-Y-X) of ``q_ned_frd``: heading from North, clockwise."""
    w, x, y, z = q.tolist()
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _quat_between(src: FloatArray, dst: FloatArray) -> FloatArray:
    """Shortest rotation taking unit vector ``src`` to ``dst`` (matrix::Quaternion(src, dst))."""
    cross = cross3(src, dst)
    dot = float(src @ dst)
    if float(cross @ cross) < 1e-10 and dot < 0.0:
        a = np.abs(src)
        axis = np.zeros(3)
        axis[int(np.argmin(a))] = 1.0
        q = np.array([0.0, *cross3(src, axis).tolist()])
    else:
        q = np.array([dot + math.sqrt(float(src @ src) * float(dst @ dst)), *cross.tolist()])
    return q / math.sqrt(float(q @ q))


def _conjugate(q: FloatArray) -> FloatArray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _frd_flu(v: FloatArray) -> FloatArray:
    """Body vector FRD <-> FLU (a pi rotation about x: y and z negated; an involution)."""
    return np.array([v[0], -v[1], -v[2]])


# --- the same on Python floats: the hot loops' fast paths ---------------------------------
# numpy's per-call overhead dominates on 3- and 4-vectors; the loops below run on floats and
# build arrays only for their outputs (tests/sim/fcu/test_fcu_math_recorded.py holds them
# within 1e-6 of the numpy implementation they replaced).

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def _fq_normalise(q: Quat) -> Quat:
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return (w / n, x / n, y / n, z / n)


def _f_cross(a: Vec3, b: Vec3) -> Vec3:
    ax, ay, az = a
    bx, by, bz = b
    return (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)


def _fq_yaw(q: Quat) -> float:
    w, x, y, z = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _fq_from_dcm_columns(bx: Vec3, by: Vec3, bz: Vec3) -> Quat:
    """:func:`quat_from_dcm` of the matrix with columns ``bx, by, bz``."""
    r00, r10, r20 = bx
    r01, r11, r21 = by
    r02, r12, r22 = bz
    trace = r00 + r11 + r22
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (0.25 * s, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s)
    elif r00 > r11 and r00 > r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        q = ((r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s)
    elif r11 > r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        q = ((r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        q = ((r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s)
    w, x, y, z = _fq_normalise(q)
    return (-w, -x, -y, -z) if w < 0.0 else (w, x, y, z)


def _f_attitude_from_thrust(thrust: Vec3, yaw: float) -> Quat:
    """:func:`attitude_from_thrust_vector` on floats."""
    tx, ty, tz = thrust
    norm = math.sqrt(tx * tx + ty * ty + tz * tz)
    body_z: Vec3 = (0.0, 0.0, 1.0) if norm < _EPS else (-tx / norm, -ty / norm, -tz / norm)
    bx = _f_cross((-math.sin(yaw), math.cos(yaw), 0.0), body_z)
    if body_z[2] < 0.0:
        bx = (-bx[0], -bx[1], -bx[2])
    if abs(body_z[2]) < 1e-6:
        bx = (0.0, 0.0, 1.0)
    n = math.sqrt(bx[0] * bx[0] + bx[1] * bx[1] + bx[2] * bx[2])
    bx = (bx[0] / n, bx[1] / n, bx[2] / n)
    return _fq_from_dcm_columns(bx, _f_cross(body_z, bx), body_z)


def _f_constrain_xy(v0: tuple[float, float], v1: tuple[float, float],
                    limit: float) -> tuple[float, float]:
    """:func:`_constrain_xy` on floats."""
    tx, ty = v0[0] + v1[0], v0[1] + v1[1]
    n0, n1 = math.hypot(*v0), math.hypot(*v1)
    if math.hypot(tx, ty) <= limit:
        return (tx, ty)
    if n0 >= limit or n1 < 1e-3:
        return (v0[0] / n0 * limit, v0[1] / n0 * limit) if n0 > _EPS else (0.0, 0.0)
    if n0 < 1e-3:
        return (v1[0] / n1 * limit, v1[1] / n1 * limit)
    u1 = (v1[0] / n1, v1[1] / n1)
    m = u1[0] * v0[0] + u1[1] * v0[1]
    c = v0[0] * v0[0] + v0[1] * v0[1] - limit * limit
    k = -m + math.sqrt(m * m - c)
    return (v0[0] + u1[0] * k, v0[1] + u1[1] * k)


# --- typed data --------------------------------------------------------------------------


def _vec3(value: npt.ArrayLike, name: str) -> FloatArray:
    arr = np.array(value, dtype=np.float64).reshape(-1)
    if arr.shape != (3,):
        raise ValueError(f"{name}: expected 3 values, got shape {np.shape(value)}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class VehicleState:
    """Estimated vehicle state as the FCU controllers see it (NED world, FRD body).

    ``q`` is ``q_ned_frd`` ``[w, x, y, z]``; arrays are read-only float64 copies.
    """

    position_ned: FloatArray  # m
    velocity_ned: FloatArray  # m/s
    q: FloatArray  # [w, x, y, z], body FRD -> world NED
    angular_velocity_frd: FloatArray  # rad/s

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_ned", _vec3(self.position_ned, "position_ned"))
        object.__setattr__(self, "velocity_ned", _vec3(self.velocity_ned, "velocity_ned"))
        q = np.array(self.q, dtype=np.float64).reshape(-1)
        norm = math.sqrt(float(q @ q)) if q.shape == (4,) else 0.0
        if not (math.isfinite(norm) and norm > _EPS):
            raise ValueError(f"q: {self.q!r} is not a finite non-zero [w, x, y, z] quaternion")
        q = q / norm
        q.setflags(write=False)
        object.__setattr__(self, "q", q)
        object.__setattr__(
            self, "angular_velocity_frd", _vec3(self.angular_velocity_frd, "angular_velocity_frd")
        )

    @classmethod
    def from_unit(cls, position_ned: Vec3, velocity_ned: Vec3, q: Quat,
                  angular_velocity_frd: Vec3) -> VehicleState:
        """A state from floats the caller vouches for (finite, ``q`` of unit norm): the
        estimator's 500 Hz output, without the checks and copies of the constructor."""
        state = object.__new__(cls)
        for name, values in (("position_ned", position_ned), ("velocity_ned", velocity_ned),
                             ("q", q), ("angular_velocity_frd", angular_velocity_frd)):
            arr = np.array(values, dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(state, name, arr)
        return state

    @classmethod
    def from_unit_arrays(cls, position_ned: FloatArray, velocity_ned: FloatArray,
                         q: FloatArray, angular_velocity_frd: FloatArray) -> VehicleState:
        """:meth:`from_unit` from read-only float64 arrays the caller hands over (no copy)."""
        state = object.__new__(cls)
        object.__setattr__(state, "position_ned", position_ned)
        object.__setattr__(state, "velocity_ned", velocity_ned)
        object.__setattr__(state, "q", q)
        object.__setattr__(state, "angular_velocity_frd", angular_velocity_frd)
        return state

    @classmethod
    def at_rest(
        cls, position_ned: npt.ArrayLike = (0.0, 0.0, 0.0), yaw: float = 0.0
    ) -> VehicleState:
        """Level, still, heading ``yaw`` [rad] at ``position_ned`` [m]."""
        q = np.array([math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)])
        return cls(np.asarray(position_ned, dtype=np.float64), np.zeros(3), q, np.zeros(3))


_NAN3 = (math.nan, math.nan, math.nan)


@dataclass(frozen=True)
class TrajectorySetpointData:
    """px4_msgs/TrajectorySetpoint semantics (NED): a NaN component is not controlled.

    Offboard modes as PX4 maps them: position (with optional velocity and acceleration
    feed-forward), velocity only (position NaN), acceleration only (position and
    velocity NaN). ``jerk`` is carried for logging only, as in PX4. ``yaw`` NaN holds the
    current heading (turning at ``yawspeed`` when that is finite).
    """

    position: FloatArray = field(default_factory=lambda: np.array(_NAN3))  # m
    velocity: FloatArray = field(default_factory=lambda: np.array(_NAN3))  # m/s
    acceleration: FloatArray = field(default_factory=lambda: np.array(_NAN3))  # m/s^2
    jerk: FloatArray = field(default_factory=lambda: np.array(_NAN3))  # m/s^3
    yaw: float = math.nan  # rad
    yawspeed: float = math.nan  # rad/s

    def __post_init__(self) -> None:
        for name in ("position", "velocity", "acceleration", "jerk"):
            object.__setattr__(self, name, _vec3(getattr(self, name), name))

    @classmethod
    def hold_position(cls, position_ned: npt.ArrayLike, yaw: float = 0.0) -> TrajectorySetpointData:
        """A position setpoint with no feed-forward."""
        return cls(position=np.asarray(position_ned, dtype=np.float64), yaw=yaw)


# --- parameters --------------------------------------------------------------------------


@dataclass(frozen=True)
class ControlGains:
    """Gains, limits and loop rates of the cascade (``config/fcu_control.yaml``).

    Velocity and rate gains are in acceleration units (m/s^2 per m/s, rad/s^2 per rad/s):
    the controllers multiply by mass and inertia, so the tune does not depend on the
    airframe's scale. Ranges and units are declared here once.
    """

    rate_loop_hz: int = param(unit="Hz", range=(50, 8000))
    attitude_loop_hz: int = param(unit="Hz", range=(10, 8000))
    position_loop_hz: int = param(unit="Hz", range=(5, 8000))
    position_p_xy: float = param(unit="1/s", range=(0.0, 10.0))
    position_p_z: float = param(unit="1/s", range=(0.0, 10.0))
    velocity_p_xy: float = param(unit="1/s", range=(0.0, 30.0))
    velocity_i_xy: float = param(unit="1/s^2", range=(0.0, 30.0))
    velocity_d_xy: float = param(unit="s/s", range=(0.0, 2.0))
    velocity_p_z: float = param(unit="1/s", range=(0.0, 30.0))
    velocity_i_z: float = param(unit="1/s^2", range=(0.0, 30.0))
    velocity_d_z: float = param(unit="s/s", range=(0.0, 2.0))
    velocity_d_cutoff_hz: float = param(unit="Hz", range=(0.5, 200.0))
    max_speed_xy: float = param(unit="m/s", range=(0.1, 20.0))
    max_speed_up: float = param(unit="m/s", range=(0.1, 10.0))
    max_speed_down: float = param(unit="m/s", range=(0.1, 10.0))
    max_tilt: float = param(unit="rad", range=(0.05, 1.5))
    thrust_min_fraction: float = param(unit="of total max thrust", range=(0.0, 0.5))
    thrust_max_fraction: float = param(unit="of total max thrust", range=(0.1, 1.0))
    thrust_xy_margin_fraction: float = param(unit="of total max thrust", range=(0.0, 0.5))
    attitude_p_roll_pitch: float = param(unit="1/s", range=(0.0, 30.0))
    attitude_p_yaw: float = param(unit="1/s", range=(0.0, 30.0))
    max_rate_roll_pitch: float = param(unit="rad/s", range=(0.1, 30.0))
    max_rate_yaw: float = param(unit="rad/s", range=(0.1, 30.0))
    rate_p_roll_pitch: float = param(unit="1/s", range=(0.0, 200.0))
    rate_i_roll_pitch: float = param(unit="1/s^2", range=(0.0, 500.0))
    rate_d_roll_pitch: float = param(unit="s/s", range=(0.0, 2.0))
    rate_integral_limit_roll_pitch: float = param(unit="rad/s^2", range=(0.0, 200.0))
    rate_p_yaw: float = param(unit="1/s", range=(0.0, 200.0))
    rate_i_yaw: float = param(unit="1/s^2", range=(0.0, 500.0))
    rate_d_yaw: float = param(unit="s/s", range=(0.0, 2.0))
    rate_integral_limit_yaw: float = param(unit="rad/s^2", range=(0.0, 200.0))
    rate_d_cutoff_hz: float = param(unit="Hz", range=(0.5, 1000.0))

    def __post_init__(self) -> None:
        validate_parameters(self)
        for name in ("attitude_loop_hz", "position_loop_hz"):
            hz = getattr(self, name)
            if hz > self.rate_loop_hz or self.rate_loop_hz % hz:
                raise ParameterError(
                    f"{hz} Hz must divide rate_loop_hz ({self.rate_loop_hz} Hz) exactly",
                    key=name,
                )
        if self.thrust_min_fraction >= self.thrust_max_fraction:
            raise ParameterError(
                f"{self.thrust_min_fraction} must be below thrust_max_fraction "
                f"({self.thrust_max_fraction})",
                key="thrust_min_fraction",
            )

    def period_us(self, hz: int) -> int:
        """Loop period [us] of a loop at ``hz`` (rounded to the microsecond)."""
        return round(_US_PER_S / hz)


# --- position control --------------------------------------------------------------------


def _lowpass_alpha(cutoff_hz: float, dt_s: float) -> float:
    return 1.0 - math.exp(-2.0 * math.pi * cutoff_hz * dt_s)


def _constrain_xy(v0: FloatArray, v1: FloatArray, limit: float) -> FloatArray:
    """``v0 + v1`` limited to norm ``limit``, keeping ``v0`` first (ControlMath::constrainXY)."""
    total = v0 + v1
    n0, n1 = float(np.hypot(*v0)), float(np.hypot(*v1))
    if float(np.hypot(*total)) <= limit:
        return total
    if n0 >= limit or n1 < 1e-3:
        return v0 / n0 * limit if n0 > _EPS else np.zeros(2)
    if n0 < 1e-3:
        return v1 / n1 * limit
    u1 = v1 / n1
    m = float(u1 @ v0)
    c = float(v0 @ v0) - limit * limit
    return v0 + u1 * (-m + math.sqrt(m * m - c))


def attitude_from_thrust_vector(thrust_ned: FloatArray, yaw: float) -> FloatArray:
    """``q_ned_frd`` pointing body -z along ``thrust_ned`` with heading ``yaw`` [rad].

    ControlMath::bodyzToAttitude: body z is ``-thrust``; body x is the yaw direction made
    orthogonal to it.
    """
    norm = math.sqrt(float(thrust_ned @ thrust_ned))
    body_z = np.array([0.0, 0.0, 1.0]) if norm < _EPS else -thrust_ned / norm
    y_c = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    body_x = cross3(y_c, body_z)
    if body_z[2] < 0.0:
        body_x = -body_x
    if abs(body_z[2]) < 1e-6:
        body_x = np.array([0.0, 0.0, 1.0])
    body_x /= math.sqrt(float(body_x @ body_x))
    body_y = cross3(body_z, body_x)
    return quat_from_dcm(np.column_stack((body_x, body_y, body_z)))


class PositionControlOutput(NamedTuple):
    """One position-loop result: setpoints after limits, thrust vector and attitude (a
    named tuple: built at 100 Hz, in one call)."""

    velocity_setpoint_ned: FloatArray  # m/s (NaN: velocity not controlled on that axis)
    acceleration_setpoint_ned: FloatArray  # m/s^2, what the velocity PID asked for
    thrust_ned: FloatArray  # N, the limited thrust vector
    collective_thrust: float  # N, |thrust_ned|
    attitude_setpoint: FloatArray  # q_ned_frd
    yawspeed_feedforward: float  # rad/s, NaN when none


def _check_setpoint(sp: TrajectorySetpointData) -> None:
    """PX4 ``PositionControl::_inputValid``: every axis controlled, x and y in pairs."""
    isfinite = math.isfinite
    fin = [[isfinite(c) for c in v.tolist()] for v in (sp.position, sp.velocity, sp.acceleration)]
    for name, mask in zip(("position", "velocity", "acceleration"), fin, strict=True):
        if mask[0] != mask[1]:
            raise InvalidSetpointError(f"{name}: x and y must both be set or both be NaN")
    for axis in range(3):
        if not any(mask[axis] for mask in fin):
            raise InvalidSetpointError(
                f"axis {'xyz'[axis]}: position, velocity and acceleration are all NaN"
            )


class PositionController:
    """P on position, PID on velocity with anti-windup, tilt and thrust limits (PX4)."""

    def __init__(self, gains: ControlGains, params: QuadrotorParams) -> None:
        self._g = gains
        self._mass = params.mass
        total = NUM_ROTORS * params.max_motor_thrust
        self._thrust_min = gains.thrust_min_fraction * total
        self._thrust_max = gains.thrust_max_fraction * total
        self._thrust_xy_margin = gains.thrust_xy_margin_fraction * total
        self._kp_pos = (gains.position_p_xy, gains.position_p_xy, gains.position_p_z)
        self._kp_vel = (gains.velocity_p_xy, gains.velocity_p_xy, gains.velocity_p_z)
        self._ki_vel = (gains.velocity_i_xy, gains.velocity_i_xy, gains.velocity_i_z)
        self._kd_vel = (gains.velocity_d_xy, gains.velocity_d_xy, gains.velocity_d_z)
        self._cos_max_tilt = math.cos(gains.max_tilt)
        self._sin_max_tilt = math.sin(gains.max_tilt)
        # the last setpoint that passed _check_setpoint (immutable: one check per setpoint,
        # not per step; an offboard setpoint is followed for several steps)
        self._checked_setpoint: TrajectorySetpointData | None = None
        self.reset()

    def reset(self) -> None:
        """Clear the integrator, the velocity-derivative filter and the held yaw."""
        self._vel_int = [0.0, 0.0, 0.0]
        self._vel_dot = [0.0, 0.0, 0.0]
        self._last_vel: Vec3 | None = None
        self._held_yaw: float | None = None

    @property
    def velocity_integral(self) -> FloatArray:
        """Velocity integrator [m/s^2] (a copy)."""
        return np.array(self._vel_int)

    def update(
        self, state: VehicleState, setpoint: TrajectorySetpointData, dt_us: int
    ) -> PositionControlOutput:
        """Run one position-loop step of ``dt_us`` microseconds."""
        n, e, d = state.position_ned.tolist()
        vn, ve, vd = state.velocity_ned.tolist()
        w, x, y, z = state.q.tolist()
        return self.update_floats((n, e, d), (vn, ve, vd), (w, x, y, z), setpoint, dt_us)

    def update_floats(self, position_ned: Vec3, velocity_ned: Vec3, q: Quat,
                      setpoint: TrajectorySetpointData, dt_us: int,
                      min_down_acceleration: float = -math.inf) -> PositionControlOutput:
        """:meth:`update` from the state's position, velocity and ``q`` as floats (the
        firmware's path: it does not build a :class:`VehicleState` for it).
        ``min_down_acceleration`` [m/s^2, NED] is the least downward acceleration the
        velocity loop may ask for: a thrust ceiling (the FCU's DESCEND, which must never
        climb on an estimate it cannot check); the vertical integrator stops against it."""
        if setpoint is not self._checked_setpoint:
            _check_setpoint(setpoint)
            self._checked_setpoint = setpoint
        isfinite = math.isfinite
        dt = max(dt_us, 1) / _US_PER_S
        g = self._g
        vel = velocity_ned
        pos = position_ned
        vel_dot = self._vel_dot
        if self._last_vel is not None:
            alpha = _lowpass_alpha(g.velocity_d_cutoff_hz, dt)
            for i in range(3):
                raw = (vel[i] - self._last_vel[i]) / dt
                vel_dot[i] += alpha * (raw - vel_dot[i])
        self._last_vel = vel

        # position P + velocity feed-forward (PositionControl::_positionControl)
        sp_pos = setpoint.position.tolist()
        sp_vel = setpoint.velocity.tolist()
        vel_from_pos = [(sp_pos[i] - pos[i]) * self._kp_pos[i] for i in range(3)]
        pos_ok = [isfinite(v) for v in vel_from_pos]
        vel_sp = [
            (sp_vel[i] + vel_from_pos[i] if isfinite(sp_vel[i]) else vel_from_pos[i])
            if pos_ok[i] else sp_vel[i]
            for i in range(3)
        ]
        if isfinite(vel_sp[0]):
            v0 = (vel_from_pos[0] if pos_ok[0] else 0.0, vel_from_pos[1] if pos_ok[1] else 0.0)
            vel_sp[0], vel_sp[1] = _f_constrain_xy(
                v0, (vel_sp[0] - v0[0], vel_sp[1] - v0[1]), g.max_speed_xy)
        if isfinite(vel_sp[2]):
            vel_sp[2] = min(max(vel_sp[2], -g.max_speed_up), g.max_speed_down)

        # velocity PID (PositionControl::_velocityControl)
        vel_int = self._vel_int
        vel_int[2] = min(max(vel_int[2], -GRAVITY), GRAVITY)
        vel_error = [vel_sp[i] - vel[i] for i in range(3)]
        acc_from_vel = [vel_error[i] * self._kp_vel[i] + vel_int[i] - vel_dot[i] * self._kd_vel[i]
                        for i in range(3)]
        sp_acc = setpoint.acceleration.tolist()
        acc_sp = [
            (sp_acc[i] + acc_from_vel[i] if isfinite(sp_acc[i]) else acc_from_vel[i])
            if isfinite(vel_sp[i]) else sp_acc[i]
            for i in range(3)
        ]
        ceiling = acc_sp[2] < min_down_acceleration
        if ceiling:
            acc_sp[2] = min_down_acceleration

        # acceleration -> thrust vector (PositionControl::_accelerationControl)
        bx, by, bz = -acc_sp[0], -acc_sp[1], GRAVITY
        n = math.sqrt(bx * bx + by * by + bz * bz)
        bx, by, bz = bx / n, by / n, bz / n
        if bz < self._cos_max_tilt:
            xy = math.hypot(bx, by)
            bx, by, bz = (bx / xy * self._sin_max_tilt, by / xy * self._sin_max_tilt,
                          self._cos_max_tilt)
        collective = self._mass * (GRAVITY - acc_sp[2]) / bz
        collective = max(collective, self._thrust_min)
        tx, ty, tz = -bx * collective, -by * collective, -bz * collective

        # vertical anti-windup, vertical priority with a horizontal margin
        at_min = -tz <= self._thrust_min + _EPS
        at_max = -tz >= self._thrust_max - _EPS
        if (at_min and vel_error[2] >= 0.0) or ((at_max or ceiling) and vel_error[2] <= 0.0):
            vel_error[2] = 0.0
        xy_norm = math.hypot(tx, ty)
        margin = min(xy_norm, self._thrust_xy_margin)
        tz = max(tz, -math.sqrt(self._thrust_max**2 - margin**2))
        xy_left = math.sqrt(max(self._thrust_max**2 - tz**2, 0.0))
        if xy_norm > xy_left:
            tx *= xy_left / xy_norm
            ty *= xy_left / xy_norm
        # tracking anti-windup, horizontal
        px, py = tx / self._mass, ty / self._mass
        wx, wy = acc_sp[0], acc_sp[1]
        lx, ly = (px, py) if wx * wx + wy * wy > px * px + py * py else (wx, wy)
        if self._kp_vel[0] > 0.0:
            vel_error[0] -= 2.0 / self._kp_vel[0] * (wx - lx)
            vel_error[1] -= 2.0 / self._kp_vel[0] * (wy - ly)
        for i in range(3):
            if isfinite(vel_error[i]):
                vel_int[i] += vel_error[i] * self._ki_vel[i] * dt

        # yaw: hold the current heading when the setpoint has none
        if isfinite(setpoint.yaw):
            yaw = setpoint.yaw
            self._held_yaw = None
        elif isfinite(setpoint.yawspeed):
            yaw = self._held_yaw = _fq_yaw(q)
        else:
            if self._held_yaw is None:
                self._held_yaw = _fq_yaw(q)
            yaw = self._held_yaw
        return PositionControlOutput(
            velocity_setpoint_ned=np.array(vel_sp),
            acceleration_setpoint_ned=np.array(acc_sp),
            thrust_ned=np.array((tx, ty, tz)),
            collective_thrust=math.sqrt(tx * tx + ty * ty + tz * tz),
            attitude_setpoint=np.array(_f_attitude_from_thrust((tx, ty, tz), yaw)),
            yawspeed_feedforward=setpoint.yawspeed,
        )


# --- attitude control ---------------------------------------------------------------------


class AttitudeController:
    """Quaternion P control with yaw de-prioritised, as PX4's ``AttitudeControl``."""

    def __init__(self, gains: ControlGains) -> None:
        kp = [gains.attitude_p_roll_pitch, gains.attitude_p_roll_pitch, gains.attitude_p_yaw]
        rp = gains.attitude_p_roll_pitch
        self._yaw_weight = min(max(gains.attitude_p_yaw / rp, 0.0), 1.0) if rp > 0.0 else 1.0
        if self._yaw_weight > 1e-4:  # the weighting scales the yaw error down: compensate
            kp[2] /= self._yaw_weight
        self._gains = np.array(
            [*kp, gains.max_rate_roll_pitch, gains.max_rate_roll_pitch, gains.max_rate_yaw,
             self._yaw_weight], dtype=np.float64)
        assert self._gains.shape == (ATT_GAINS_SIZE,)

    def update(
        self, q: FloatArray, q_setpoint: FloatArray, yawspeed_feedforward: float = math.nan
    ) -> FloatArray:
        """Body-rate setpoint [rad/s, FRD] driving ``q`` (q_ned_frd) to ``q_setpoint``."""
        w, x, y, z = q.tolist()
        sw, sx, sy, sz = q_setpoint.tolist()
        return np.array(self.update_quat((w, x, y, z), (sw, sx, sy, sz), yawspeed_feedforward))

    def update_quat(self, q: Quat, q_setpoint: Quat,
                    yawspeed_feedforward: float = math.nan) -> Vec3:
        """:meth:`update` on Python floats (the firmware's 250 Hz path; the arithmetic is
        :func:`sim.fcu.kernels.attitude_kernel`)."""
        qw, qx, qy, qz = q
        sw, sx, sy, sz = q_setpoint
        rate_sp: Vec3 = attitude_kernel(self._gains, qw, qx, qy, qz, sw, sx, sy, sz,
                                        float(yawspeed_feedforward))
        return rate_sp


# --- rate control -------------------------------------------------------------------------

class RateController:
    """PID on body rates with anti-windup -> body torque [N m, FRD] (PX4 ``RateControl``).

    The step runs in :func:`sim.fcu.kernels.rate_kernel` on a state array (integrator,
    derivative filter, last rate, the mixer's saturation flags)."""

    def __init__(self, gains: ControlGains, params: QuadrotorParams) -> None:
        ix, iy, iz = params.inertia
        rp, yw = "roll_pitch", "yaw"
        axes = (rp, rp, yw)
        self._gains = np.array(
            [float(getattr(gains, f"rate_p_{a}")) for a in axes]
            + [float(getattr(gains, f"rate_i_{a}")) for a in axes]
            + [float(getattr(gains, f"rate_d_{a}")) for a in axes]
            + [float(getattr(gains, f"rate_integral_limit_{a}")) for a in axes]
            + [float(ix), float(iy), float(iz), float(gains.rate_d_cutoff_hz)])
        assert self._gains.shape == (RATE_GAINS_SIZE,)
        self._st = np.zeros(RATE_STATE_SIZE)
        self._saturation = self._st[10:16]  # a view: the mixer's flags are copied in
        self.reset()

    def reset(self) -> None:
        """Clear the integrator, the derivative filter and the saturation flags."""
        self._st[:] = 0.0

    @property
    def integral(self) -> FloatArray:
        """Rate integrator [rad/s^2] (a copy)."""
        return self._st[0:3].copy()

    def set_saturation(self, positive: npt.ArrayLike, negative: npt.ArrayLike) -> None:
        """Per-axis flags from the mixer: the torque could not grow / shrink any further."""
        self._st[10:13] = np.asarray(positive, dtype=bool).reshape(3)
        self._st[13:16] = np.asarray(negative, dtype=bool).reshape(3)

    def update(
        self, rate_frd: Sequence[float] | FloatArray,
        rate_setpoint_frd: Sequence[float] | FloatArray, dt_us: int, landed: bool = False
    ) -> FloatArray:
        """Torque setpoint [N m, FRD] for one step of ``dt_us`` microseconds."""
        r0, r1, r2 = rate_frd
        s0, s1, s2 = rate_setpoint_frd
        return np.array(self.update_floats((float(r0), float(r1), float(r2)),
                                           (float(s0), float(s1), float(s2)),
                                           int(dt_us), bool(landed)))

    def update_floats(self, rate_frd: Vec3, rate_setpoint_frd: Vec3, dt_us: int,
                      landed: bool) -> Vec3:
        """:meth:`update` on Python floats, int and bool (the firmware's 500 Hz path;
        other types, numpy's float32 say, would compile the kernel for them)."""
        r0, r1, r2 = rate_frd
        s0, s1, s2 = rate_setpoint_frd
        torque: Vec3 = rate_kernel(self._st, self._gains, r0, r1, r2, s0, s1, s2, dt_us, landed)
        return torque

    def set_saturation_flags(self, flags: FloatArray) -> None:
        """:meth:`set_saturation` from a :class:`Mixer`'s flags (positive 3, negative 3, as
        1.0/0.0), without conversions: the firmware's 500 Hz path."""
        self._saturation[...] = flags


# --- mixer with desaturation ----------------------------------------------------------------


@dataclass(frozen=True)
class MixerOutput:
    """Rotor thrusts [N] (sim.quadrotor order) and what desaturation had to give up."""

    motor_thrusts: FloatArray  # N, each in [0, max_motor_thrust]
    collective_thrust: float  # N, achieved by the allocation (before the final clip)
    saturated_positive: npt.NDArray[np.bool_]  # per FRD torque axis: could not increase
    saturated_negative: npt.NDArray[np.bool_]  # per FRD torque axis: could not decrease


@functools.cache
def _mixer_columns(params: QuadrotorParams) -> tuple[tuple[float, ...], ...]:
    """Rotor thrusts per unit collective thrust and per unit FLU torque about x, y, z."""
    return tuple(tuple(mix(params, t, (x, y, z)).tolist()) for t, x, y, z in np.eye(4).tolist())


class Mixer:
    """:func:`mix_with_desaturation` for one airframe into a reused buffer (the firmware's
    500 Hz path): after :meth:`mix`, ``out`` holds the four rotor thrusts [N], the achieved
    collective thrust [N], then the saturation flags (positive 3, negative 3) as 1.0/0.0."""

    def __init__(self, params: QuadrotorParams) -> None:
        self._cols = np.array(_mixer_columns(params))
        self._hi = float(params.max_motor_thrust)
        self.out = np.zeros(11)
        self._thrusts = self.out[0:4]  # views of the reused buffer
        self._flags = self.out[5:11]

    def mix(self, collective_thrust: float, torque_frd: Sequence[float] | FloatArray) -> None:
        """PX4's sequential desaturation (see :func:`mix_with_desaturation`)."""
        tx, ty, tz = torque_frd
        mix_kernel(self._cols, float(collective_thrust), float(tx), float(ty), float(tz), 0.0,
                   self._hi, self.out)

    @property
    def motor_thrusts(self) -> FloatArray:
        """Rotor thrusts [N] of the last :meth:`mix` (a copy)."""
        return self._thrusts.copy()

    @property
    def saturation_flags(self) -> FloatArray:
        """Saturated positive (3) then negative (3) of the last :meth:`mix`, as 1.0/0.0."""
        return self._flags


@functools.cache
def _mixer(params: QuadrotorParams) -> Mixer:
    return Mixer(params)


def mix_with_desaturation(
    params: QuadrotorParams, collective_thrust: float, torque_frd: FloatArray
) -> MixerOutput:
    """Rotor thrusts for a collective thrust [N] and torque [N m, FRD], airmode off.

    PX4's sequential desaturation: mix thrust, roll and pitch; reduce collective thrust
    (never increase it) to unsaturate; then scale roll, then pitch; then add yaw, scaling
    it with 15 % headroom above the top, and reduce thrust again. Attitude authority thus
    wins over collective thrust, and yaw gives way first. (The arithmetic is
    :func:`sim.fcu.kernels.mix_kernel`.)
    """
    mixer = _mixer(params)
    mixer.mix(collective_thrust, torque_frd)
    out = mixer.out
    return MixerOutput(
        motor_thrusts=out[0:4].copy(),
        collective_thrust=float(out[4]),
        saturated_positive=out[5:8] != 0.0,
        saturated_negative=out[8:11] != 0.0,
    )


# --- the cascade --------------------------------------------------------------------------


@dataclass(frozen=True)
class CascadeOutput:
    """One rate-loop tick of the cascade: every setpoint level, then the motors."""

    motor_thrusts: FloatArray  # N, sim.quadrotor rotor order, in [0, max_motor_thrust]
    collective_thrust: float  # N, after desaturation
    torque_setpoint_frd: FloatArray  # N m
    rate_setpoint_frd: FloatArray  # rad/s
    attitude_setpoint: FloatArray  # q_ned_frd
    velocity_setpoint_ned: FloatArray  # m/s
    acceleration_setpoint_ned: FloatArray  # m/s^2
    saturated: bool  # the mixer had to give up some torque


class Cascade:
    """Position (``position_loop_hz``) -> attitude (``attitude_loop_hz``) -> rate (each call).

    Call :meth:`update` once per rate-loop period with the elapsed FCU time ``dt_us``;
    the outer loops run when their own period has elapsed (the first call after
    :meth:`reset` runs all three). :meth:`reset` on arming clears every integrator.
    """

    def __init__(self, gains: ControlGains, params: QuadrotorParams | None = None) -> None:
        self.gains = gains
        self.params = params if params is not None else QuadrotorParams()
        self.position = PositionController(gains, self.params)
        self.attitude = AttitudeController(gains)
        self.rate = RateController(gains, self.params)
        self._pos_period_us = gains.period_us(gains.position_loop_hz)
        self._att_period_us = gains.period_us(gains.attitude_loop_hz)
        self.reset()

    def reset(self) -> None:
        """Forget integrators, filters and held setpoints (call on arming)."""
        self.position.reset()
        self.rate.reset()
        self._pos_elapsed_us: int | None = None
        self._att_elapsed_us: int | None = None
        self._pos_out: PositionControlOutput | None = None
        self._rate_sp = np.zeros(3)

    @staticmethod
    def _due(elapsed_us: int | None, dt_us: int, period_us: int) -> int:
        """The outer loop's dt [us] if it runs on this tick, else 0 (first tick: period)."""
        if elapsed_us is None:
            return period_us
        total = elapsed_us + dt_us
        return total if total + dt_us // 2 >= period_us else 0

    def update(
        self, state: VehicleState, setpoint: TrajectorySetpointData, dt_us: int
    ) -> CascadeOutput:
        """One rate-loop tick, ``dt_us`` microseconds after the previous one."""
        if dt_us <= 0:
            raise ValueError(f"dt_us: {dt_us} us must be > 0")
        pos_dt = self._due(self._pos_elapsed_us, dt_us, self._pos_period_us)
        if pos_dt or self._pos_out is None:
            self._pos_out = self.position.update(state, setpoint, pos_dt)
            self._pos_elapsed_us = 0
        else:
            self._pos_elapsed_us = (self._pos_elapsed_us or 0) + dt_us
        pos = self._pos_out
        if self._due(self._att_elapsed_us, dt_us, self._att_period_us):
            self._rate_sp = self.attitude.update(
                state.q, pos.attitude_setpoint, pos.yawspeed_feedforward
            )
            self._att_elapsed_us = 0
        else:
            self._att_elapsed_us = (self._att_elapsed_us or 0) + dt_us
        torque = self.rate.update(state.angular_velocity_frd, self._rate_sp, dt_us)
        mixed = mix_with_desaturation(self.params, pos.collective_thrust, torque)
        self.rate.set_saturation(mixed.saturated_positive, mixed.saturated_negative)
        return CascadeOutput(
            motor_thrusts=mixed.motor_thrusts,
            collective_thrust=mixed.collective_thrust,
            torque_setpoint_frd=torque,
            rate_setpoint_frd=self._rate_sp.copy(),
            attitude_setpoint=pos.attitude_setpoint,
            velocity_setpoint_ned=pos.velocity_setpoint_ned,
            acceleration_setpoint_ned=pos.acceleration_setpoint_ned,
            saturated=bool(mixed.saturated_positive.any() or mixed.saturated_negative.any()),
        )
