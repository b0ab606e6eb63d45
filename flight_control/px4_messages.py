"""ENU/FLU <-> NED/FRD message builders for the PX4 contract: one definition of each.

- :func:`vision_odometry` builds the ``/fmu/in/vehicle_visual_odometry`` message
  (px4_msgs/VehicleOdometry, NED world, FRD body) from a pose in the ENU ``map`` frame with
  an FLU body and its ROS covariance (6x6 row-major: x, y, z, roll, pitch, yaw).
- :func:`odometry_enu` reads a px4_msgs/VehicleOdometry back into the ENU/FLU quantities
  the companion publishes on ``/fcu/odometry``.
- :func:`trajectory_setpoint` builds the ``/fmu/in/trajectory_setpoint`` message (NED) from
  an ENU reference, and :func:`offboard_control_mode` the heartbeat that says which of its
  terms PX4 should track; :func:`vehicle_command` a command from the companion. NaN
  means "not controlled" on both sides and stays NaN.

Variances follow the axes: ENU x is NED y, so the x and y position variances swap. The
attitude variances are about the body axes; FLU and FRD share the roll axis and flip the
pitch and yaw axes' signs, which leaves variances unchanged. Pure: numpy and the typed
message API only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import (
    FloatArray,
    Quat,
    Vec3,
    enu_to_ned_f,
    frd_to_flu_f,
    ned_to_enu_f,
    quat_conjugate_f,
    quat_enu_flu_to_ned_frd_f,
    quat_ned_frd_to_enu_flu_f,
    quat_rotate_f,
    variance_enu_to_ned_f,
    variance_ned_to_enu_f,
    yaw_enu_to_ned,
    yaw_rate_enu_to_ned,
)
from interfaces.px4 import (
    COMPANION_COMPONENT_ID,
    FCU_COMPONENT_ID,
    FCU_SYSTEM_ID,
    ODOMETRY_QUALITY_BEST,
    PoseFrame,
    VelocityFrame,
)

__all__ = ["OdometryEnu", "odometry_enu", "offboard_control_mode", "trajectory_setpoint",
           "vehicle_command", "vision_odometry"]

# a row-major 6x6's diagonal is every 7th of its 36 values: x, y, z, roll, pitch, yaw
_POSITION_DIAG = slice(0, 21, 7)  # x, y, z
_ATTITUDE_DIAG = slice(21, 36, 7)  # roll, pitch, yaw
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
        position=np.array(enu_to_ned_f(position_enu), dtype=np.float32),
        q=np.array(quat_enu_flu_to_ned_frd_f(q_enu_flu), dtype=np.float32),
        velocity_frame=int(VelocityFrame.NED), velocity=_NAN3.copy(),
        angular_velocity=_NAN3.copy(),
        position_variance=np.array(variance_enu_to_ned_f(cov[_POSITION_DIAG].tolist()),
                                   dtype=np.float32),
        orientation_variance=cov[_ATTITUDE_DIAG].astype(np.float32),
        velocity_variance=_NAN3.copy(), quality=VISION_QUALITY)


@dataclass(frozen=True)
class OdometryEnu:
    """A px4_msgs/VehicleOdometry in companion frames.

    ``position`` [m] and ``velocity`` [m/s] in the ENU map frame, ``q`` (w, x, y, z) the
    FLU body's attitude, ``body_velocity`` [m/s] and ``angular_velocity`` [rad/s] in FLU,
    each as Python floats; and the ROS 6x6 covariances (36 values, NaN where PX4 gave
    none)."""

    position: Vec3
    q: Quat
    velocity: Vec3
    body_velocity: Vec3
    angular_velocity: Vec3
    pose_covariance: FloatArray
    twist_covariance: FloatArray


def odometry_enu(msg: Any) -> OdometryEnu:
    """Read a px4_msgs/VehicleOdometry (NED/FRD, velocity in NED) into ENU/FLU.

    The bridge calls this at 100 Hz, so the vectors go through the float versions of the
    :mod:`flight_control.frames` conversions: the body velocity is the ENU velocity rotated
    by the inverse of the (normalised) attitude."""
    q = quat_ned_frd_to_enu_flu_f(msg.q.tolist())
    velocity = ned_to_enu_f(msg.velocity.tolist())
    pose_cov = np.zeros(36)
    pose_cov[_POSITION_DIAG] = variance_ned_to_enu_f(msg.position_variance.tolist())
    pose_cov[_ATTITUDE_DIAG] = msg.orientation_variance
    twist_cov = np.zeros(36)
    twist_cov[_POSITION_DIAG] = variance_ned_to_enu_f(msg.velocity_variance.tolist())
    return OdometryEnu(
        position=ned_to_enu_f(msg.position.tolist()), q=q, velocity=velocity,
        body_velocity=quat_rotate_f(quat_conjugate_f(q), velocity),
        angular_velocity=frd_to_flu_f(msg.angular_velocity.tolist()),
        pose_covariance=pose_cov, twist_covariance=twist_cov)


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
        position=np.array(enu_to_ned_f(position_enu), dtype=np.float32),
        velocity=np.array(enu_to_ned_f(velocity_enu), dtype=np.float32),
        acceleration=np.array(enu_to_ned_f(acceleration_enu), dtype=np.float32),
        jerk=_NAN3.copy(), yaw=yaw_enu_to_ned(yaw) if math.isfinite(yaw) else math.nan,
        yawspeed=yaw_rate_enu_to_ned(float(yaw_rate_enu)))


def offboard_control_mode(setpoint: Any, *, timestamp_us: int) -> Any:
    """px4_msgs/OffboardControlMode for a TrajectorySetpoint: a term is controlled when
    any axis of it is finite (PX4 tracks the finite axes and leaves NaN ones free)."""
    return interfaces.new(
        "px4_msgs/msg/OffboardControlMode", timestamp=int(timestamp_us),
        position=_any_finite(setpoint.position), velocity=_any_finite(setpoint.velocity),
        acceleration=_any_finite(setpoint.acceleration))


def vehicle_command(command: int, params: Sequence[float], *, timestamp_us: int) -> Any:
    """``/fmu/in/vehicle_command`` (px4_msgs/VehicleCommand): ``command`` with its seven
    parameters, from the companion to the FCU (MAVLink ids of :mod:`interfaces.px4`)."""
    p1, p2, p3, p4, p5, p6, p7 = map(float, params)
    return interfaces.new(
        "px4_msgs/msg/VehicleCommand", timestamp=timestamp_us, command=command,
        param1=p1, param2=p2, param3=p3, param4=p4, param5=p5, param6=p6, param7=p7,
        target_system=FCU_SYSTEM_ID, target_component=FCU_COMPONENT_ID,
        source_system=FCU_SYSTEM_ID, source_component=COMPANION_COMPONENT_ID,
        from_external=True)


def _any_finite(values: Any) -> bool:
    """``bool(np.isfinite(values).any())`` for a short array, on Python floats."""
    return any(map(math.isfinite, values.tolist()))
