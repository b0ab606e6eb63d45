"""The companion-side messages the FCU bridge publishes, built from the FCU's: ENU ``map``
and FLU ``base_link`` (REP 103), stamped on the companion clock (the caller converts the
FCU's sample time). One builder per message; pure: numpy and the typed message API only,
so each is tested without a node. The px4 side's builders are in
:mod:`flight_control.px4_messages`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import FloatArray, frd_to_flu_f, quat_to_xyzw
from flight_control.pose_history import PoseSample
from flight_control.px4_messages import OdometryEnu

__all__ = ["BODY_FRAME", "MAP_FRAME", "all_finite", "battery", "command_ack", "imu",
           "nan_to_num", "odometry", "pose_odometry", "timesync_diagnostics"]

MAP_FRAME = "map"
BODY_FRAME = "base_link"

# /fcu/odometry's classes, built directly at 100 Hz (every field given; validated when
# published), as rclpy code would build them
_ODOMETRY: Any = interfaces.get_message("nav_msgs/msg/Odometry")
_HEADER: Any = interfaces.get_message("std_msgs/msg/Header")
_POSE_COV: Any = interfaces.get_message("geometry_msgs/msg/PoseWithCovariance")
_POSE: Any = interfaces.get_message("geometry_msgs/msg/Pose")
_POINT: Any = interfaces.get_message("geometry_msgs/msg/Point")
_QUATERNION: Any = interfaces.get_message("geometry_msgs/msg/Quaternion")
_TWIST_COV: Any = interfaces.get_message("geometry_msgs/msg/TwistWithCovariance")
_TWIST: Any = interfaces.get_message("geometry_msgs/msg/Twist")
_VECTOR3: Any = interfaces.get_message("geometry_msgs/msg/Vector3")


def _vec3(msg_type: str, v: Sequence[float]) -> Any:
    x, y, z = v
    return interfaces.new(msg_type, x=x, y=y, z=z)


def _header(stamp: Any, frame_id: str = "") -> Any:
    return interfaces.new("std_msgs/msg/Header", stamp=stamp, frame_id=frame_id)


def all_finite(values: Sequence[float]) -> bool:
    """``np.isfinite(values).all()`` for a few Python floats."""
    return all(map(math.isfinite, values))


def nan_to_num(values: FloatArray) -> FloatArray:
    """``np.nan_to_num(values)`` for a float64 array; the array itself when it is finite
    already (the common case, without numpy's per-call cost)."""
    return values if all_finite(values.tolist()) else np.nan_to_num(values)


def odometry(odo: OdometryEnu, stamp: Any) -> Any:
    """``/fcu/odometry`` (nav_msgs/Odometry) from the FCU's odometry read in ENU/FLU; NaN
    covariances (unknown) become 0."""
    w, x, y, z = odo.q
    px, py, pz = odo.position
    vx, vy, vz = odo.body_velocity
    rx, ry, rz = odo.angular_velocity
    return _ODOMETRY(
        header=_HEADER(stamp=stamp, frame_id=MAP_FRAME),
        child_frame_id=BODY_FRAME,
        pose=_POSE_COV(
            pose=_POSE(position=_POINT(x=px, y=py, z=pz),
                       orientation=_QUATERNION(x=x, y=y, z=z, w=w)),
            covariance=nan_to_num(odo.pose_covariance)),
        twist=_TWIST_COV(
            twist=_TWIST(linear=_VECTOR3(x=vx, y=vy, z=vz),
                         angular=_VECTOR3(x=rx, y=ry, z=rz)),
            covariance=nan_to_num(odo.twist_covariance)),
    )


def imu(msg: Any, stamp: Any) -> Any:
    """``/fcu/imu`` (sensor_msgs/Imu, FLU) from px4_msgs/SensorCombined (FRD); it carries no
    orientation (covariance[0] = -1, as REP 145 says)."""
    gyro = frd_to_flu_f(msg.gyro_rad.tolist())
    accel = frd_to_flu_f(msg.accelerometer_m_s2.tolist())
    return interfaces.new(
        "sensor_msgs/msg/Imu", header=_header(stamp, BODY_FRAME),
        orientation_covariance=np.array([-1.0] + [0.0] * 8),
        angular_velocity=_vec3("geometry_msgs/msg/Vector3", gyro),
        linear_acceleration=_vec3("geometry_msgs/msg/Vector3", accel))


def battery(msg: Any, stamp: Any) -> Any:
    """``/fcu/battery`` (sensor_msgs/BatteryState) from px4_msgs/BatteryStatus: current
    positive while charging (ROS), capacity in Ah."""
    return interfaces.new(
        "sensor_msgs/msg/BatteryState", header=_header(stamp),
        voltage=float(msg.voltage_v), current=-float(msg.current_a),
        charge=math.nan, capacity=float(msg.capacity) / 1000.0,
        design_capacity=float(msg.capacity) / 1000.0, percentage=float(msg.remaining),
        power_supply_status=2, power_supply_health=1, power_supply_technology=3,
        present=bool(msg.connected))


def command_ack(msg: Any, stamp: Any) -> Any:
    """``/fcu/command_ack`` from px4_msgs/VehicleCommandAck."""
    return interfaces.new(
        "quadmission_interfaces/msg/FcuCommandAck", header=_header(stamp),
        command=int(msg.command), result=int(msg.result),
        result_param1=int(msg.result_param1))


def timesync_diagnostics(est: Any, stamp: Any) -> Any:
    """``/fcu/timesync_status`` from a time-sync estimate."""
    return interfaces.new(
        "quadmission_interfaces/msg/TimesyncDiagnostics", header=_header(stamp),
        offset_observed_us=est.observed_offset_us, offset_estimated_us=est.offset_us,
        skew_estimated_us=est.skew_ppm, rtt_us=est.rtt_us, samples=est.samples,
        high_deviation_count=est.high_deviation_total, high_rtt_count=est.high_rtt_total,
        resets=est.resets, converged=est.converged)


def pose_odometry(sample: PoseSample, stamp: Any) -> Any:
    """The pose ``/fcu/pose_at`` answers with (nav_msgs/Odometry, pose only)."""
    x, y, z, w = quat_to_xyzw(sample.q)
    return interfaces.new(
        "nav_msgs/msg/Odometry", header=_header(stamp, MAP_FRAME), child_frame_id=BODY_FRAME,
        pose=interfaces.new("geometry_msgs/msg/PoseWithCovariance", pose=interfaces.new(
            "geometry_msgs/msg/Pose",
            position=_vec3("geometry_msgs/msg/Point", sample.position.tolist()),
            orientation=interfaces.new("geometry_msgs/msg/Quaternion", x=float(x),
                                       y=float(y), z=float(z), w=float(w)))))
