"""ENU/FLU <-> NED/FRD message builders for the PX4 contract: one definition of each.

- :func:`vision_odometry` builds the ``/fmu/in/vehicle_visual_odometry`` message
  (px4_msgs/VehicleOdometry, NED world, FRD body) from a pose in the ENU ``map`` frame with
  an FLU body and its ROS covariance (6x6 row-major: x, y, z, roll, pitch, yaw).
- :func:`odometry_enu` reads a px4_msgs/VehicleOdometry back into the ENU/FLU quantities
  the companion publishes on ``/fcu/odometry``.
- :func:`trajectory_setpoint` builds the ``/fmu/in/trajectory_setpoint`` message (NED) from
  an ENU reference, and :func:`offboard_control_mode` the heartbeat that says which of its
  terms PX4 should track. NaN means "not controlled" on both sides and stays NaN.

Variances follow the axes: ENU x is NED y, so the x and y position variances swap. The
attitude variances are about the body axes; FLU and FRD share the roll axis and flip the
pitch and yaw axes' signs, which leaves variances unchanged. Pure: numpy and the typed
message API only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import (
    Q_ENU_NED,
    Q_FRD_FLU,
    FloatArray,
    enu_to_ned,
    quat_enu_flu_to_ned_frd,
    variance_enu_to_ned,
    yaw_enu_to_ned,
    yaw_rate_enu_to_ned,
)
from interfaces.px4 import ODOMETRY_QUALITY_BEST, PoseFrame, VelocityFrame

__all__ = ["OdometryEnu", "odometry_enu", "offboard_control_mode", "trajectory_setpoint",
           "vision_odometry"]

_POSITION_DIAG = (0, 7, 14)  # x, y, z in a 6x6 row-major ROS covariance
_ATTITUDE_DIAG = (21, 28, 35)  # roll, pitch, yaw
_NAN3 = np.full(3, math.nan, dtype=np.float32)
VISION_QUALITY = ODOMETRY_QUALITY_BEST  # a simulated vision pose is never degraded


def vision_odometry(position_enu: Any, q_enu_flu: Any, covariance: Any, *, timestamp_us: int,
                    timestamp_sample_us: int) -> Any:
    """px4_msgs/VehicleOdometry for an external-vision pose.

    ``q_enu_flu`` is (w, x, y, z); ``covariance`` is a ROS 6x6 pose covariance in the ENU
    map frame (36 values, row-major). Velocities are unknown (NaN), as for a pose-only
    vision system."""
    cov = np.asarray(covariance, dtype=np.float64).reshape(36)
    return interfaces.new(
        "px4_msgs/msg/VehicleOdometry", timestamp=int(timestamp_us),
        timestamp_sample=int(timestamp_sample_us), pose_frame=int(PoseFrame.NED),
        position=enu_to_ned(position_enu).astype(np.float32),
        q=np.asarray(quat_enu_flu_to_ned_frd(q_enu_flu), dtype=np.float32),
        velocity_frame=int(VelocityFrame.NED), velocity=_NAN3.copy(),
        angular_velocity=_NAN3.copy(),
        position_variance=variance_enu_to_ned(cov[list(_POSITION_DIAG)]).astype(np.float32),
        orientation_variance=cov[list(_ATTITUDE_DIAG)].astype(np.float32),
        velocity_variance=_NAN3.copy(), quality=VISION_QUALITY)


@dataclass(frozen=True)
class OdometryEnu:
    """A px4_msgs/VehicleOdometry in companion frames.

    ``position`` [m] and ``velocity`` [m/s] in the ENU map frame, ``q`` (w, x, y, z) the
    FLU body's attitude, ``body_velocity`` [m/s] and ``angular_velocity`` [rad/s] in FLU,
    and the ROS 6x6 covariances (36 values, NaN where PX4 gave none)."""

    position: FloatArray
    q: FloatArray
    velocity: FloatArray
    body_velocity: FloatArray
    angular_velocity: FloatArray
    pose_covariance: FloatArray
    twist_covariance: FloatArray


def _f_quat_multiply(p: tuple[float, ...], q: tuple[float, ...]) -> tuple[float, ...]:
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw)


_Q_ENU_NED = tuple(Q_ENU_NED.tolist())
_Q_FRD_FLU = tuple(Q_FRD_FLU.tolist())


def odometry_enu(msg: Any) -> OdometryEnu:
    """Read a px4_msgs/VehicleOdometry (NED/FRD, velocity in NED) into ENU/FLU.

    The same conversions as :mod:`flight_control.frames` (``quat_ned_frd_to_enu_flu``,
    ``ned_to_enu``, ``frd_to_flu``, ``quat_rotate``), on Python floats: the bridge calls
    this at 100 Hz, and numpy's broadcasting helpers cost more than the arithmetic on one
    vector (``tests/flight_control/test_px4_messages.py`` checks it against them)."""
    q = _f_quat_multiply(_f_quat_multiply(_Q_ENU_NED, tuple(msg.q.tolist())), _Q_FRD_FLU)
    vn, ve, vd = msg.velocity.tolist()
    velocity = (ve, vn, -vd)
    n, e, d = msg.position.tolist()
    wx, wy, wz = msg.angular_velocity.tolist()
    pv = msg.position_variance.tolist()
    ov = msg.orientation_variance.tolist()
    vv = msg.velocity_variance.tolist()
    pose_cov = [0.0] * 36
    twist_cov = [0.0] * 36
    for k, (i, j) in enumerate(zip(_POSITION_DIAG, _ATTITUDE_DIAG, strict=True)):
        pose_cov[i] = pv[(1, 0, 2)[k]]
        pose_cov[j] = ov[k]
        twist_cov[i] = vv[(1, 0, 2)[k]]
    # the body velocity: the ENU velocity rotated by the inverse of the normalised q
    w, x, y, z = q
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if norm > 0.0 and math.isfinite(norm):
        w, ux, uy, uz = w / norm, -x / norm, -y / norm, -z / norm
    else:
        w = ux = uy = uz = math.nan
    vx, vy, vz = velocity
    tx, ty, tz = 2.0 * (uy * vz - uz * vy), 2.0 * (uz * vx - ux * vz), 2.0 * (ux * vy - uy * vx)
    body = (vx + w * tx + (uy * tz - uz * ty), vy + w * ty + (uz * tx - ux * tz),
            vz + w * tz + (ux * ty - uy * tx))
    return OdometryEnu(
        position=np.array((e, n, -d)), q=np.array(q), velocity=np.array(velocity),
        body_velocity=np.array(body), angular_velocity=np.array((wx, -wy, -wz)),
        pose_covariance=np.array(pose_cov), twist_covariance=np.array(twist_cov))


def trajectory_setpoint(position_enu: Any, velocity_enu: Any, acceleration_enu: Any,
                        yaw_enu: float, yaw_rate_enu: float, *, timestamp_us: int) -> Any:
    """px4_msgs/TrajectorySetpoint (NED) for an ENU reference.

    ``position_enu`` [m], ``velocity_enu`` [m/s] and ``acceleration_enu`` [m/s^2] are ENU
    3-vectors, ``yaw_enu`` [rad] from East counter-clockwise about Up and ``yaw_rate_enu``
    [rad/s] about Up. A NaN axis or yaw is left uncontrolled and stays NaN; jerk is never
    set."""
    yaw = float(yaw_enu)
    return interfaces.new(
        "px4_msgs/msg/TrajectorySetpoint", timestamp=int(timestamp_us),
        position=enu_to_ned(position_enu).astype(np.float32),
        velocity=enu_to_ned(velocity_enu).astype(np.float32),
        acceleration=enu_to_ned(acceleration_enu).astype(np.float32), jerk=_NAN3.copy(),
        yaw=float(yaw_enu_to_ned(yaw)) if math.isfinite(yaw) else math.nan,
        yawspeed=float(yaw_rate_enu_to_ned(float(yaw_rate_enu))))


def offboard_control_mode(setpoint: Any, *, timestamp_us: int) -> Any:
    """px4_msgs/OffboardControlMode for a TrajectorySetpoint: a term is controlled when
    any axis of it is finite (PX4 tracks the finite axes and leaves NaN ones free)."""
    return interfaces.new(
        "px4_msgs/msg/OffboardControlMode", timestamp=int(timestamp_us),
        position=bool(np.isfinite(setpoint.position).any()),
        velocity=bool(np.isfinite(setpoint.velocity).any()),
        acceleration=bool(np.isfinite(setpoint.acceleration).any()))
