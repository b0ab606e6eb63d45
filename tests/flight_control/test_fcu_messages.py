"""The bridge's companion-side message builders, without a node: frames, units, flags."""

from __future__ import annotations

import math

import numpy as np

import interfaces
from flight_control import fcu_messages
from flight_control.pose_history import PoseSample
from flight_control.px4_messages import odometry_enu, vehicle_command
from interfaces.px4 import COMPANION_COMPONENT_ID, FCU_COMPONENT_ID, FCU_SYSTEM_ID

STAMP = interfaces.new("builtin_interfaces/msg/Time", sec=12, nanosec=345)


def test_odometry_is_stamped_in_the_map_frame_and_unknown_covariances_become_zero() -> None:
    msg = interfaces.new(
        "px4_msgs/msg/VehicleOdometry", position=np.array([1.0, 2.0, -3.0], np.float32),
        q=np.array([1.0, 0.0, 0.0, 0.0], np.float32),
        velocity=np.array([0.5, 0.0, 0.0], np.float32),
        angular_velocity=np.zeros(3, np.float32),
        position_variance=np.array([0.01, 0.04, math.nan], np.float32),
        orientation_variance=np.full(3, math.nan, np.float32),
        velocity_variance=np.full(3, math.nan, np.float32))
    odo = fcu_messages.odometry(odometry_enu(msg), STAMP)
    assert (odo.header.stamp.sec, odo.header.stamp.nanosec) == (12, 345)
    assert (odo.header.frame_id, odo.child_frame_id) == ("map", "base_link")
    p = odo.pose.pose.position
    assert (p.x, p.y, p.z) == (2.0, 1.0, 3.0)  # NED north, east, down -> ENU east, north, up
    cov = odo.pose.covariance
    assert np.isfinite(cov).all() and np.isfinite(odo.twist.covariance).all()
    assert math.isclose(cov[0], 0.04, rel_tol=1e-6)  # ENU x variance is NED y's
    assert math.isclose(cov[7], 0.01, rel_tol=1e-6)
    assert cov[14] == 0.0  # NaN (unknown) -> 0


def test_imu_turns_frd_into_flu_and_says_it_carries_no_orientation() -> None:
    msg = interfaces.new("px4_msgs/msg/SensorCombined",
                         gyro_rad=np.array([0.1, 0.2, 0.3], np.float32),
                         accelerometer_m_s2=np.array([1.0, 2.0, -9.81], np.float32))
    imu = fcu_messages.imu(msg, STAMP)
    assert imu.header.frame_id == "base_link" and imu.header.stamp.nanosec == 345
    assert imu.orientation_covariance[0] == -1.0  # REP 145: no orientation estimate
    g, a = imu.angular_velocity, imu.linear_acceleration
    assert np.allclose([g.x, g.y, g.z], [0.1, -0.2, -0.3])
    assert np.allclose([a.x, a.y, a.z], [1.0, -2.0, 9.81])


def test_battery_current_is_positive_while_charging_and_capacity_in_ah() -> None:
    msg = interfaces.new("px4_msgs/msg/BatteryStatus", voltage_v=15.2, current_a=12.5,
                         capacity=5000, remaining=0.4, connected=True)
    state = fcu_messages.battery(msg, STAMP)
    assert state.current == -12.5  # PX4: discharge positive; ROS: discharge negative
    assert state.capacity == 5.0 and state.design_capacity == 5.0
    assert math.isclose(state.percentage, 0.4, rel_tol=1e-6) and state.present


def test_the_pose_at_answer_carries_the_kept_pose_as_xyzw() -> None:
    sample = PoseSample(5, np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.5, 0.5, 0.5]),
                        np.zeros(3))
    odo = fcu_messages.pose_odometry(sample, STAMP)
    q = odo.pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.5, 0.5, 0.5, 0.5)
    p = odo.pose.pose.position
    assert (p.x, p.y, p.z) == (1.0, 2.0, 3.0)
    assert odo.header.stamp.sec == 12 and odo.header.frame_id == "map"


def test_a_companion_command_is_addressed_to_the_fcu_from_the_companion() -> None:
    cmd = vehicle_command(400, [1, 0, 0, 0, 0, 0, 21196], timestamp_us=99)
    assert (cmd.target_system, cmd.target_component) == (FCU_SYSTEM_ID, FCU_COMPONENT_ID)
    assert (cmd.source_system, cmd.source_component) == (FCU_SYSTEM_ID,
                                                          COMPANION_COMPONENT_ID)
    assert cmd.command == 400 and cmd.param1 == 1.0 and cmd.param7 == 21196.0
    assert cmd.timestamp == 99 and cmd.from_external


def test_nan_to_num_keeps_a_finite_array_as_it_is() -> None:
    finite = np.array([1.0, 2.0])
    assert fcu_messages.nan_to_num(finite) is finite
    assert fcu_messages.nan_to_num(np.array([math.nan, 1.0])).tolist() == [0.0, 1.0]
