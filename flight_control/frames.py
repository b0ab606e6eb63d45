"""Frames and quaternions for the FCU <-> ROS boundary (pure: numpy only).

Frames (DESIGN.md, "Frames, units, time"):

=====  ======  ==========================  ===============================================
frame  kind    axes                        used by
=====  ======  ==========================  ===============================================
NED    world   x North, y East, z Down     px4_msgs positions, velocities, setpoints
FRD    body    x Forward, y Right, z Down  px4_msgs attitude, gyro, accelerometer
ENU    world   x East, y North, z Up       ``map`` above the bridge (REP 103)
FLU    body    x Forward, y Left, z Up     ``base_link`` above the bridge (REP 103)
=====  ======  ==========================  ===============================================

Quaternions are Hamilton, scalar first, ``[w, x, y, z]`` (PX4's ``float32[4] q``).
``geometry_msgs/Quaternion`` has fields ``x, y, z, w``: use :func:`quat_to_xyzw` /
:func:`quat_from_xyzw` at a message boundary. ``q_a_b`` rotates a vector expressed in
frame ``b`` into frame ``a`` (``v_a = q_a_b (x) v_b (x) q_a_b*``), so PX4's
``VehicleAttitude.q`` / ``VehicleOdometry.q`` is ``q_ned_frd`` and ``nav_msgs/Odometry``
carries ``q_enu_flu``. Euler angles are ``[roll, pitch, yaw]`` of the intrinsic Z-Y-X
sequence (yaw, then pitch, then roll), as PX4's ``matrix::Eulerf`` and tf2's ``setRPY``.

Conversions follow px4_ros_com ``frame_transforms`` (``include/px4_ros_com/
frame_transforms.h``, ``src/lib/frame_transforms.cpp``):

* world vectors NED <-> ENU: ``(x, y, z) -> (y, x, -z)``. px4_ros_com applies it as a
  permutation and a reflection (``NED_ENU_REFLECTION_XY``/``_Z``), not as a rotation
  product, so a NaN stays in its own component; so do we.
* body vectors FRD <-> FLU: ``(x, y, z) -> (x, -y, -z)``, a pi rotation about x
  (``AIRCRAFT_BASELINK_Q``).
* orientation: ``px4_to_ros_orientation(q) = NED_ENU_Q * q * AIRCRAFT_BASELINK_Q`` with
  ``NED_ENU_Q = quaternion_from_euler(pi, 0, pi/2) = [0, sqrt(1/2), sqrt(1/2), 0]``. We use
  ``Q_ENU_NED (x) q_ned_frd (x) Q_FRD_FLU``, the same rotation; the sign differs (``q`` and
  ``-q`` are one rotation), chosen so that the level North-facing attitude maps to
  ``[sqrt(1/2), 0, 0, sqrt(1/2)]`` (w > 0) and the conversion is an exact involution.
* Euler angles: roll unchanged, pitch negated, ``yaw_enu = pi/2 - yaw_ned`` wrapped to
  (-pi, pi] (PX4 yaw: from North, clockwise; ENU yaw: from East, counter-clockwise).

Every vector function accepts shape ``(3,)`` or ``(..., 3)`` (quaternions ``(..., 4)``),
computes in float64 and returns float64 (cast with ``.astype(np.float32)`` for a px4_msgs
array field). NaN is PX4's "not set": it propagates per component through the static frame
changes, to the whole result through a rotation, and never raises a floating-point
warning. Shape errors raise ValueError naming the argument.

The per-message paths (the bridge at 100 Hz, the flight-control node's observation) work on
one vector at a time, where numpy's per-call cost is microseconds and the arithmetic
nanoseconds: the ``*_f`` functions at the end of the module do the same conversions on a
tuple of Python floats, with the same formulas in the same operation order, so they give
bit-identical results (``tests/flight_control/test_frames.py`` pins each pair). A scalar
:func:`wrap_pi` (and so the ``yaw_*`` conversions) computes on floats too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Final, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Q_ENU_NED",
    "Q_FRD_FLU",
    "Quat",
    "Vec3",
    "covariance_enu_to_ned",
    "covariance_flu_to_frd",
    "covariance_frd_to_flu",
    "covariance_ned_to_enu",
    "enu_to_ned",
    "enu_to_ned_f",
    "euler_enu_flu_to_ned_frd",
    "euler_ned_frd_to_enu_flu",
    "flu_to_frd",
    "frd_to_flu",
    "frd_to_flu_f",
    "ned_to_enu",
    "ned_to_enu_f",
    "quat_angle_between",
    "quat_canonical",
    "quat_conjugate",
    "quat_conjugate_f",
    "quat_enu_flu_to_ned_frd",
    "quat_enu_flu_to_ned_frd_f",
    "quat_from_euler",
    "quat_from_rotation_matrix",
    "quat_from_xyzw",
    "quat_from_yaw",
    "quat_multiply",
    "quat_multiply_f",
    "quat_ned_frd_to_enu_flu",
    "quat_ned_frd_to_enu_flu_f",
    "quat_normalise",
    "quat_normalise_f",
    "quat_rotate",
    "quat_rotate_f",
    "quat_to_euler",
    "quat_to_rotation_matrix",
    "quat_to_xyzw",
    "quat_to_yaw",
    "quat_to_yaw_f",
    "quat_to_yaw_roll_pitch",
    "variance_enu_to_ned",
    "variance_enu_to_ned_f",
    "variance_ned_to_enu",
    "variance_ned_to_enu_f",
    "wrap_pi",
    "yaw_enu_to_ned",
    "yaw_ned_to_enu",
    "yaw_rate_enu_to_ned",
    "yaw_rate_ned_to_enu",
]

FloatArray = NDArray[np.float64]
Scalar = float | np.floating[Any]
#: One vector or quaternion as Python floats, for the ``*_f`` functions.
Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def _frozen(values: list[float]) -> FloatArray:
    out = np.array(values, dtype=np.float64)
    out.setflags(write=False)
    return out


_SQRT_HALF: Final = math.sqrt(0.5)
_TWO_PI: Final = 2.0 * math.pi

#: Rotation NED -> ENU as a quaternion ``[w, x, y, z]``: a pi rotation about the axis
#: (North + East) / sqrt(2); px4_ros_com's ``NED_ENU_Q`` (its own inverse up to sign).
Q_ENU_NED: Final[FloatArray] = _frozen([0.0, _SQRT_HALF, _SQRT_HALF, 0.0])

#: Rotation FLU -> FRD body as a quaternion ``[w, x, y, z]``: a pi rotation about the
#: forward axis; px4_ros_com's ``AIRCRAFT_BASELINK_Q`` up to sign.
Q_FRD_FLU: Final[FloatArray] = _frozen([0.0, -1.0, 0.0, 0.0])

# cos(pitch) below which the Euler decomposition is treated as gimbal-locked (roll := 0):
# above it the atan2 of the two tiny matrix terms is accurate to ~eps / cos(pitch).
_GIMBAL_LOCK_COS: Final = 1e-8

# Index maps and sign masks of the static frame changes (see the module docstring).
_SWAP_XY: Final = np.array([1, 0, 2])
_NEG_Z: Final[FloatArray] = _frozen([1.0, 1.0, -1.0])
_NEG_YZ: Final[FloatArray] = _frozen([1.0, -1.0, -1.0])


# --- argument checks -------------------------------------------------------------------


def _last_axis(value: ArrayLike, size: int, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != size:
        raise ValueError(f"{name}: expected shape ({size},) or (..., {size}), got {arr.shape}")
    return arr


def _vec3(value: ArrayLike, name: str = "v") -> FloatArray:
    return _last_axis(value, 3, name)


def _quat(value: ArrayLike, name: str = "q") -> FloatArray:
    return _last_axis(value, 4, name)


def _mat3(value: ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name}: expected shape (3, 3) or (..., 3, 3), got {arr.shape}")
    return arr


# --- angles ----------------------------------------------------------------------------


@overload
def wrap_pi(angle: Scalar) -> float: ...
@overload
def wrap_pi(angle: NDArray[Any]) -> FloatArray: ...
def wrap_pi(angle: Scalar | NDArray[Any]) -> float | FloatArray:
    """``angle`` [rad] wrapped to (-pi, pi]; NaN (and +-inf) gives NaN.

    A Python or numpy scalar gives a float, computed on Python floats (whose ``%`` is
    ``np.mod``: the sign of the divisor); an array (0-d included) gives an array.
    """
    if not isinstance(angle, np.ndarray):
        out = math.pi - (math.pi - float(angle)) % _TWO_PI
        # the modulo may round a tiny negative up to exactly 2 pi, which would give -pi
        return out + _TWO_PI if out <= -math.pi else out
    a = np.asarray(angle, dtype=np.float64)
    with np.errstate(invalid="ignore"):  # +-inf -> NaN without a warning
        arr = math.pi - np.mod(math.pi - a, _TWO_PI)
    out_arr: FloatArray = np.where(arr <= -math.pi, arr + _TWO_PI, arr)
    return out_arr


# --- quaternion algebra (any frames; [w, x, y, z], Hamilton) ---------------------------


def quat_normalise(q: ArrayLike) -> FloatArray:
    """``q / |q|`` for ``[w, x, y, z]`` of shape (4,) or (..., 4).

    A zero, infinite or NaN quaternion gives all NaN (PX4's "invalid"), without a warning.
    """
    arr = _quat(q)
    norm = np.sqrt(np.sum(arr * arr, axis=-1, keepdims=True))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = arr / norm
    return np.where(np.isfinite(out).all(axis=-1, keepdims=True), out, np.nan)


def quat_canonical(q: ArrayLike) -> FloatArray:
    """``q`` or ``-q`` (the same rotation), whichever has ``w >= 0``."""
    arr = _quat(q)
    return np.where(arr[..., :1] < 0.0, -arr, arr)


def quat_conjugate(q: ArrayLike) -> FloatArray:
    """``[w, -x, -y, -z]``: the inverse rotation of a unit quaternion (``q_b_a`` from ``q_a_b``)."""
    return _quat(q) * np.array([1.0, -1.0, -1.0, -1.0])


def quat_multiply(p: ArrayLike, q: ArrayLike) -> FloatArray:
    """Hamilton product ``p (x) q``; broadcasts over leading axes.

    Composes rotations: ``q_a_c = quat_multiply(q_a_b, q_b_c)``.
    """
    p_arr, q_arr = _quat(p, "p"), _quat(q, "q")
    pw, px, py, pz = np.moveaxis(p_arr, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q_arr, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def quat_rotate(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """``v_a = q_a_b (x) v_b (x) q_a_b*``: vector ``v`` in frame b expressed in frame a.

    ``q`` is normalised first (message quaternions are float32); broadcasts ``(..., 4)``
    against ``(..., 3)``. E.g. ``quat_rotate(q_ned_frd, v_frd)`` is ``v`` in NED.
    """
    qn = quat_normalise(q)
    vec = _vec3(v)
    w, u = qn[..., :1], qn[..., 1:]
    t = 2.0 * np.cross(u, vec)
    out: FloatArray = vec + w * t + np.cross(u, t)
    return out


def quat_to_rotation_matrix(q: ArrayLike) -> FloatArray:
    """Rotation matrix ``R_a_b`` (``v_a = R_a_b @ v_b``) of ``q_a_b``; shape (..., 3, 3).

    ``q`` is normalised first.
    """
    w, x, y, z = np.moveaxis(quat_normalise(q), -1, 0)
    rows = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def quat_from_rotation_matrix(r: ArrayLike) -> FloatArray:
    """``q_a_b`` (``w >= 0``, unit) of a rotation matrix ``R_a_b`` of shape (..., 3, 3).

    Shepperd's method: ``K = 4 q q^T`` is linear in ``R``; its row with the largest
    diagonal entry is ``q`` times a well-conditioned scale, so normalising it gives ``q``.
    A NaN anywhere in a matrix gives an all-NaN quaternion.
    """
    m = _mat3(r, "r")
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    rows = [
        [1.0 + m00 + m11 + m22, m21 - m12, m02 - m20, m10 - m01],
        [m21 - m12, 1.0 + m00 - m11 - m22, m01 + m10, m02 + m20],
        [m02 - m20, m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21],
        [m10 - m01, m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22],
    ]
    k = np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)  # (..., 4, 4)
    best = np.argmax(np.diagonal(k, axis1=-2, axis2=-1), axis=-1)
    q = np.take_along_axis(k, best[..., None, None], axis=-2)[..., 0, :]
    return quat_canonical(quat_normalise(q))


def quat_from_yaw(yaw: ArrayLike) -> FloatArray:
    """Level attitude with heading ``yaw`` [rad] about the world z axis; shape (..., 4).

    Frame-agnostic: a NED yaw gives ``q_ned_frd``, an ENU yaw gives ``q_enu_flu``.
    """
    half = 0.5 * np.asarray(yaw, dtype=np.float64)
    zero = np.zeros_like(half)
    return np.stack([np.cos(half), zero, zero, np.sin(half)], axis=-1)


def quat_from_euler(roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike) -> FloatArray:
    """``q = q_z(yaw) (x) q_y(pitch) (x) q_x(roll)`` [rad]; arguments broadcast; (..., 4).

    Frame-agnostic: NED/FRD angles give ``q_ned_frd``, ENU/FLU angles give ``q_enu_flu``
    (convert the angles with :func:`euler_ned_frd_to_enu_flu`).
    """
    r = 0.5 * np.asarray(roll, dtype=np.float64)
    p = 0.5 * np.asarray(pitch, dtype=np.float64)
    y = 0.5 * np.asarray(yaw, dtype=np.float64)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack(
        np.broadcast_arrays(
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ),
        axis=-1,
    )


def _euler_from_matrix(m: FloatArray) -> FloatArray:
    """[roll, pitch, yaw] of the Z-Y-X decomposition of ``m`` (..., 3, 3)."""
    cos_pitch = np.hypot(m[..., 0, 0], m[..., 1, 0])
    pitch = np.arctan2(-m[..., 2, 0], cos_pitch)
    locked = cos_pitch < _GIMBAL_LOCK_COS  # pitch = +-pi/2: only yaw -+ roll is defined
    roll = np.where(locked, 0.0, np.arctan2(m[..., 2, 1], m[..., 2, 2]))
    yaw = np.where(
        locked,
        np.arctan2(-m[..., 0, 1], m[..., 1, 1]),
        np.arctan2(m[..., 1, 0], m[..., 0, 0]),
    )
    return np.stack([wrap_pi(np.asarray(roll)), pitch, wrap_pi(np.asarray(yaw))], axis=-1)


def quat_to_euler(q: ArrayLike) -> FloatArray:
    """``[roll, pitch, yaw]`` [rad] of ``q`` (Z-Y-X, inverse of :func:`quat_from_euler`).

    Shape (..., 3); roll and yaw in (-pi, pi], pitch in [-pi/2, pi/2]. At pitch = +-pi/2
    (gimbal lock) roll is 0 and yaw carries the whole heading, so the angles still give
    back the same rotation. Frame-agnostic like :func:`quat_from_euler`.
    """
    return _euler_from_matrix(quat_to_rotation_matrix(q))


def quat_to_yaw(q: ArrayLike) -> FloatArray:
    """Euler yaw [rad] in (-pi, pi] of ``q``; shape ``q.shape[:-1]`` (0-d for one quaternion).

    Equal to ``quat_to_euler(q)[..., 2]``; away from gimbal lock it is px4_ros_com's
    ``quaternion_get_yaw`` (``atan2(2(wz + xy), 1 - 2(y^2 + z^2))``). A ``q_ned_frd`` gives
    the NED yaw (PX4 ``heading``), a ``q_enu_flu`` the ENU yaw.
    """
    out: FloatArray = quat_to_euler(q)[..., 2]
    return out


def quat_angle_between(p: ArrayLike, q: ArrayLike) -> FloatArray:
    """Angle [rad] in [0, pi] of the rotation taking ``p`` to ``q`` (0 for ``q == -p``).

    Shape of the broadcast leading axes (0-d for two single quaternions).
    """
    d = quat_multiply(quat_conjugate(quat_normalise(p)), quat_normalise(q))
    out: FloatArray = 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))
    return out


def quat_to_xyzw(q: ArrayLike) -> FloatArray:
    """PX4 order ``[w, x, y, z]`` -> geometry_msgs field order ``[x, y, z, w]``."""
    return np.roll(_quat(q), -1, axis=-1)


def quat_from_xyzw(q_xyzw: ArrayLike) -> FloatArray:
    """geometry_msgs field order ``[x, y, z, w]`` -> PX4 order ``[w, x, y, z]``."""
    return np.roll(_quat(q_xyzw, "q_xyzw"), 1, axis=-1)


# --- static frame changes --------------------------------------------------------------


def ned_to_enu(v_ned: ArrayLike) -> FloatArray:
    """A world vector (position, velocity, acceleration) from NED to ENU: ``(y, x, -z)``.

    Shape (3,) or (..., 3); NaN stays in its own component (North NaN -> ENU y NaN).
    """
    return _vec3(v_ned, "v_ned")[..., _SWAP_XY] * _NEG_Z


def enu_to_ned(v_enu: ArrayLike) -> FloatArray:
    """A world vector from ENU to NED: ``(y, x, -z)``; the inverse of :func:`ned_to_enu`."""
    return _vec3(v_enu, "v_enu")[..., _SWAP_XY] * _NEG_Z


def frd_to_flu(v_frd: ArrayLike) -> FloatArray:
    """A body vector from FRD to FLU: ``(x, -y, -z)``.

    For any body-fixed vector: angular velocity (a pi rotation maps it like a vector),
    gyro and accelerometer readings, body velocity. NaN stays in its own component.
    """
    return _vec3(v_frd, "v_frd") * _NEG_YZ


def flu_to_frd(v_flu: ArrayLike) -> FloatArray:
    """A body vector from FLU to FRD: ``(x, -y, -z)``; the inverse of :func:`frd_to_flu`."""
    return _vec3(v_flu, "v_flu") * _NEG_YZ


def quat_ned_frd_to_enu_flu(q_ned_frd: ArrayLike) -> FloatArray:
    """Attitude ``q_ned_frd`` (FRD body -> NED world, PX4's ``VehicleAttitude.q``) to
    ``q_enu_flu`` (FLU body -> ENU world, what ``nav_msgs/Odometry`` carries).

    ``Q_ENU_NED (x) q_ned_frd (x) Q_FRD_FLU``: px4_ros_com's ``px4_to_ros_orientation`` up
    to sign (see the module docstring). Level and facing North (identity) gives
    ``[sqrt(1/2), 0, 0, sqrt(1/2)]``, ENU yaw pi/2. Not normalised; NaN spreads to all
    four components.
    """
    return quat_multiply(quat_multiply(Q_ENU_NED, _quat(q_ned_frd, "q_ned_frd")), Q_FRD_FLU)


def quat_enu_flu_to_ned_frd(q_enu_flu: ArrayLike) -> FloatArray:
    """Attitude ``q_enu_flu`` (FLU body -> ENU world) to ``q_ned_frd`` (FRD body -> NED).

    ``Q_ENU_NED* (x) q_enu_flu (x) Q_FRD_FLU*``, px4_ros_com's ``ros_to_px4_orientation``
    up to sign; exactly undoes :func:`quat_ned_frd_to_enu_flu`.
    """
    q = _quat(q_enu_flu, "q_enu_flu")
    return quat_multiply(quat_multiply(quat_conjugate(Q_ENU_NED), q), quat_conjugate(Q_FRD_FLU))


def euler_ned_frd_to_enu_flu(rpy_ned_frd: ArrayLike) -> FloatArray:
    """``[roll, pitch, yaw]`` of ``q_ned_frd`` -> those of ``q_enu_flu``: ``[r, -p, pi/2 - y]``.

    A roll right stays a positive roll, a nose-up pitch becomes negative, yaw is
    :func:`yaw_ned_to_enu`. Shape (3,) or (..., 3).
    """
    rpy = _vec3(rpy_ned_frd, "rpy_ned_frd")
    yaw = wrap_pi(0.5 * math.pi - rpy[..., 2])
    return np.stack([rpy[..., 0], -rpy[..., 1], yaw], axis=-1)


def euler_enu_flu_to_ned_frd(rpy_enu_flu: ArrayLike) -> FloatArray:
    """``[roll, pitch, yaw]`` of ``q_enu_flu`` -> those of ``q_ned_frd``: ``[r, -p, pi/2 - y]``."""
    return euler_ned_frd_to_enu_flu(_vec3(rpy_enu_flu, "rpy_enu_flu"))


@overload
def yaw_ned_to_enu(yaw_ned: Scalar) -> float: ...
@overload
def yaw_ned_to_enu(yaw_ned: NDArray[Any]) -> FloatArray: ...
def yaw_ned_to_enu(yaw_ned: Scalar | NDArray[Any]) -> float | FloatArray:
    """PX4 yaw [rad] (from North, clockwise about Down) -> ENU yaw (from East,
    counter-clockwise about Up): ``pi/2 - yaw_ned`` wrapped to (-pi, pi].

    North (0) -> pi/2, East (pi/2) -> 0, West (-pi/2) -> pi. NaN stays NaN.
    """
    if isinstance(yaw_ned, np.ndarray):
        return wrap_pi(0.5 * math.pi - yaw_ned.astype(np.float64))
    return wrap_pi(0.5 * math.pi - float(yaw_ned))


@overload
def yaw_enu_to_ned(yaw_enu: Scalar) -> float: ...
@overload
def yaw_enu_to_ned(yaw_enu: NDArray[Any]) -> FloatArray: ...
def yaw_enu_to_ned(yaw_enu: Scalar | NDArray[Any]) -> float | FloatArray:
    """ENU yaw [rad] -> PX4 yaw: ``pi/2 - yaw_enu`` wrapped to (-pi, pi]; NaN stays NaN."""
    return yaw_ned_to_enu(yaw_enu)


@overload
def yaw_rate_ned_to_enu(yaw_rate_ned: Scalar) -> float: ...
@overload
def yaw_rate_ned_to_enu(yaw_rate_ned: NDArray[Any]) -> FloatArray: ...
def yaw_rate_ned_to_enu(yaw_rate_ned: Scalar | NDArray[Any]) -> float | FloatArray:
    """Yaw rate [rad/s] about NED Down (``TrajectorySetpoint.yawspeed``) -> about ENU Up.

    Negated. For body rates use :func:`frd_to_flu`.
    """
    if isinstance(yaw_rate_ned, np.ndarray):
        return -yaw_rate_ned.astype(np.float64)
    return -float(yaw_rate_ned)


@overload
def yaw_rate_enu_to_ned(yaw_rate_enu: Scalar) -> float: ...
@overload
def yaw_rate_enu_to_ned(yaw_rate_enu: NDArray[Any]) -> FloatArray: ...
def yaw_rate_enu_to_ned(yaw_rate_enu: Scalar | NDArray[Any]) -> float | FloatArray:
    """Yaw rate [rad/s] about ENU Up -> about NED Down: negated."""
    return yaw_rate_ned_to_enu(yaw_rate_enu)


# --- uncertainty -----------------------------------------------------------------------


def variance_ned_to_enu(var_ned: ArrayLike) -> FloatArray:
    """Per-axis variances of a world vector (``position_variance``, ``velocity_variance``)
    from NED to ENU: x and y swapped, z kept (a sign flip does not change a variance).

    Body-frame variances (``orientation_variance``) need no change between FRD and FLU.
    """
    return _vec3(var_ned, "var_ned")[..., _SWAP_XY]


def variance_enu_to_ned(var_enu: ArrayLike) -> FloatArray:
    """Per-axis variances of a world vector from ENU to NED: x and y swapped."""
    return _vec3(var_enu, "var_enu")[..., _SWAP_XY]


def _permute_reflect(cov: FloatArray, signs: FloatArray, order: NDArray[Any]) -> FloatArray:
    # P C P^T for P = diag(signs) @ permutation, by indexing: NaN stays in its own entry
    out: FloatArray = cov[..., order, :][..., :, order] * np.multiply.outer(signs, signs)
    return out


def covariance_ned_to_enu(cov_ned: ArrayLike) -> FloatArray:
    """A 3x3 world covariance (..., 3, 3) from NED to ENU, as px4_ros_com's
    ``transform_static_frame(Covariance3d, NED_TO_ENU)``: rows and columns x/y swapped,
    the x-z and y-z terms negated.
    """
    return _permute_reflect(_mat3(cov_ned, "cov_ned"), _NEG_Z, _SWAP_XY)


def covariance_enu_to_ned(cov_enu: ArrayLike) -> FloatArray:
    """A 3x3 world covariance from ENU to NED; the inverse of :func:`covariance_ned_to_enu`."""
    return _permute_reflect(_mat3(cov_enu, "cov_enu"), _NEG_Z, _SWAP_XY)


def covariance_frd_to_flu(cov_frd: ArrayLike) -> FloatArray:
    """A 3x3 body covariance (..., 3, 3) from FRD to FLU: the x-y and x-z terms negated."""
    return _permute_reflect(_mat3(cov_frd, "cov_frd"), _NEG_YZ, np.arange(3))


def covariance_flu_to_frd(cov_flu: ArrayLike) -> FloatArray:
    """A 3x3 body covariance from FLU to FRD; the inverse of :func:`covariance_frd_to_flu`."""
    return _permute_reflect(_mat3(cov_flu, "cov_flu"), _NEG_YZ, np.arange(3))


# --- one vector or quaternion on Python floats -----------------------------------------
#
# The conversions above for a single vector or quaternion given as Python floats (any
# sequence of 3 or 4; a numpy array works but is slower than its ``.tolist()``), returned
# as a tuple. Same formulas, same operation order, so the same bits (NaN's sign aside);
# see the module docstring. A wrong length raises ValueError naming the argument.


def _vec3_f(value: Sequence[float], name: str) -> Vec3:
    try:
        x, y, z = value
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected shape (3,), got {np.shape(value)}") from None
    return (x, y, z)


def _quat_f(value: Sequence[float], name: str) -> Quat:
    try:
        w, x, y, z = value
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected shape (4,), got {np.shape(value)}") from None
    return (w, x, y, z)


_NAN4: Final[Quat] = (math.nan, math.nan, math.nan, math.nan)
_Q_ENU_NED_F: Final = _quat_f(Q_ENU_NED.tolist(), "Q_ENU_NED")
_Q_FRD_FLU_F: Final = _quat_f(Q_FRD_FLU.tolist(), "Q_FRD_FLU")
_Q_NED_ENU_F: Final = _quat_f(quat_conjugate(Q_ENU_NED).tolist(), "Q_NED_ENU")
_Q_FLU_FRD_F: Final = _quat_f(quat_conjugate(Q_FRD_FLU).tolist(), "Q_FLU_FRD")


def quat_normalise_f(q: Sequence[float]) -> Quat:
    """:func:`quat_normalise` of one ``[w, x, y, z]``: all NaN unless ``q / |q|`` is finite."""
    w, x, y, z = _quat_f(q, "q")
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if norm == 0.0:  # numpy's 0 / 0; Python would raise
        return _NAN4
    out = (w / norm, x / norm, y / norm, z / norm)
    return out if all(map(math.isfinite, out)) else _NAN4


def quat_conjugate_f(q: Sequence[float]) -> Quat:
    """:func:`quat_conjugate` of one ``[w, x, y, z]``: ``[w, -x, -y, -z]``."""
    w, x, y, z = _quat_f(q, "q")
    return (w, -x, -y, -z)


def quat_multiply_f(p: Sequence[float], q: Sequence[float]) -> Quat:
    """:func:`quat_multiply` of two quaternions: the Hamilton product ``p (x) q``."""
    pw, px, py, pz = _quat_f(p, "p")
    qw, qx, qy, qz = _quat_f(q, "q")
    return (pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw)


def quat_rotate_f(q: Sequence[float], v: Sequence[float]) -> Vec3:
    """:func:`quat_rotate` of one vector: ``v`` in frame b expressed in frame a, for
    ``q = q_a_b`` (normalised first; an invalid ``q`` gives all NaN)."""
    w, x, y, z = quat_normalise_f(q)
    vx, vy, vz = _vec3_f(v, "v")
    # t = 2 u x v, then v + w t + u x t, as np.cross orders the terms
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


def quat_to_yaw_f(q: Sequence[float]) -> float:
    """:func:`quat_to_yaw` of one quaternion: Euler yaw [rad] in (-pi, pi].

    The gimbal-lock test uses ``math.hypot``, which can differ from ``np.hypot`` in the
    last bit: the two may choose differently within an ulp of the threshold, where both
    yaws describe the rotation.
    """
    w, x, y, z = quat_normalise_f(q)
    m00, m10 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z)
    if math.hypot(m00, m10) < _GIMBAL_LOCK_COS:  # see _euler_from_matrix
        yaw = math.atan2(-2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z))
    else:
        yaw = math.atan2(m10, m00)
    return wrap_pi(yaw)


def ned_to_enu_f(v_ned: Sequence[float]) -> Vec3:
    """:func:`ned_to_enu` of one world vector: ``(y, x, -z)``."""
    x, y, z = _vec3_f(v_ned, "v_ned")
    return (y, x, -z)


def enu_to_ned_f(v_enu: Sequence[float]) -> Vec3:
    """:func:`enu_to_ned` of one world vector: ``(y, x, -z)``."""
    x, y, z = _vec3_f(v_enu, "v_enu")
    return (y, x, -z)


def frd_to_flu_f(v_frd: Sequence[float]) -> Vec3:
    """:func:`frd_to_flu` of one body vector: ``(x, -y, -z)``."""
    x, y, z = _vec3_f(v_frd, "v_frd")
    return (x, -y, -z)


def variance_ned_to_enu_f(var_ned: Sequence[float]) -> Vec3:
    """:func:`variance_ned_to_enu` of one world vector's variances: x and y swapped."""
    x, y, z = _vec3_f(var_ned, "var_ned")
    return (y, x, z)


def variance_enu_to_ned_f(var_enu: Sequence[float]) -> Vec3:
    """:func:`variance_enu_to_ned` of one world vector's variances: x and y swapped."""
    x, y, z = _vec3_f(var_enu, "var_enu")
    return (y, x, z)


def quat_ned_frd_to_enu_flu_f(q_ned_frd: Sequence[float]) -> Quat:
    """:func:`quat_ned_frd_to_enu_flu` of one attitude (not normalised)."""
    q = _quat_f(q_ned_frd, "q_ned_frd")
    return quat_multiply_f(quat_multiply_f(_Q_ENU_NED_F, q), _Q_FRD_FLU_F)


def quat_enu_flu_to_ned_frd_f(q_enu_flu: Sequence[float]) -> Quat:
    """:func:`quat_enu_flu_to_ned_frd` of one attitude (not normalised)."""
    q = _quat_f(q_enu_flu, "q_enu_flu")
    return quat_multiply_f(quat_multiply_f(_Q_NED_ENU_F, q), _Q_FLU_FRD_F)


# --- Euler angles of one quaternion in closed form ---------------------------------------
#
# Not one of the ``*_f`` pairs above: the same angles as :func:`quat_to_euler` in its
# convention, by other formulas (no matrix, no normalising, ``asin`` for the pitch), so they
# differ from it in the last bits. Precision landing reads the vehicle's attitude with it;
# its flights were measured with these numbers, so it keeps them.


def quat_to_yaw_roll_pitch(q: Sequence[float]) -> tuple[float, float, float]:
    """``(yaw, roll, pitch)`` [rad] of one unit ``[w, x, y, z]``: :func:`quat_to_euler`'s
    Z-Y-X angles (in another order), in closed form: yaw and roll ``atan2`` in [-pi, pi],
    pitch ``asin`` of its sine clamped to [-1, 1]. ``q`` is not normalised: give a unit
    one. Away from gimbal lock it agrees with :func:`quat_to_euler` to round-off; at it
    (pitch = +-pi/2) roll and yaw share the heading differently."""
    w, x, y, z = _quat_f(q, "q")
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    return yaw, roll, pitch
