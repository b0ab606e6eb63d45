"""The ENU/FLU <-> NED/FRD message builders: axes, covariances and a round trip."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import interfaces
from flight_control.frames import quat_angle_between, quat_from_euler
from flight_control.px4_messages import odometry_enu, vision_odometry
from interfaces.px4 import PoseFrame

coord = st.floats(-50.0, 50.0, allow_nan=False)
angle = st.floats(-3.1, 3.1, allow_nan=False)
variance = st.floats(1e-6, 10.0, allow_nan=False)


def _cov(diag: list[float]) -> np.ndarray:
    cov = np.zeros((6, 6))
    cov[np.diag_indices(6)] = diag
    return cov.reshape(36)


def test_vision_position_and_variances_follow_the_axes() -> None:
    # 1 m east, 2 m north, 3 m up; x (east) variance 0.01, y (north) 0.04, z 0.09
    msg = vision_odometry([1.0, 2.0, 3.0], [1.0, 0.0, 0.0, 0.0],
                          _cov([0.01, 0.04, 0.09, 0.1, 0.2, 0.3]),
                          timestamp_us=10, timestamp_sample_us=7)
    np.testing.assert_allclose(msg.position, [2.0, 1.0, -3.0])  # north, east, down
    np.testing.assert_allclose(msg.position_variance, [0.04, 0.01, 0.09], rtol=1e-6)
    np.testing.assert_allclose(msg.orientation_variance, [0.1, 0.2, 0.3], rtol=1e-6)
    assert msg.pose_frame == PoseFrame.NED
    assert (msg.timestamp, msg.timestamp_sample) == (10, 7)
    assert np.all(np.isnan(msg.velocity))


def test_heading_east_in_enu_is_heading_east_in_ned() -> None:
    # ENU yaw 0 faces east; NED yaw of east is +pi/2
    msg = vision_odometry([0, 0, 0], [1.0, 0.0, 0.0, 0.0], np.zeros(36), timestamp_us=0,
                          timestamp_sample_us=0)
    w, x, y, z = (float(v) for v in msg.q)
    yaw_ned = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    assert abs(yaw_ned - np.pi / 2) < 1e-6


@given(x=coord, y=coord, z=coord, roll=angle, pitch=st.floats(-1.4, 1.4), yaw=angle,
       var=st.lists(variance, min_size=6, max_size=6))
def test_vision_then_odometry_gives_back_the_pose(x: float, y: float, z: float, roll: float,
                                                   pitch: float, yaw: float,
                                                   var: list[float]) -> None:
    q = quat_from_euler(roll, pitch, yaw)
    msg = vision_odometry([x, y, z], q, _cov(var), timestamp_us=0, timestamp_sample_us=0)
    wire = interfaces.deserialize(interfaces.serialize(msg, "px4_msgs/msg/VehicleOdometry"),
                                  "px4_msgs/msg/VehicleOdometry")
    back = odometry_enu(wire)
    np.testing.assert_allclose(back.position, [x, y, z], atol=1e-4 * (1 + abs(x) + abs(y)
                                                                      + abs(z)))
    assert float(quat_angle_between(back.q, q)) < 1e-5
    diag = back.pose_covariance.reshape(6, 6).diagonal()
    np.testing.assert_allclose(diag, var, rtol=1e-6)


def test_odometry_velocity_is_rotated_into_the_body() -> None:
    # heading north (ENU yaw +pi/2), flying north at 1 m/s: body forward speed 1 m/s
    msg = vision_odometry([0, 0, 1], quat_from_euler(0.0, 0.0, np.pi / 2), np.zeros(36),
                          timestamp_us=0, timestamp_sample_us=0)
    msg.velocity = np.array([1.0, 0.0, 0.0], dtype=np.float32)  # NED: north
    msg.velocity_variance = np.array([0.5, 0.1, 0.2], dtype=np.float32)
    odo = odometry_enu(msg)
    np.testing.assert_allclose(odo.velocity, [0.0, 1.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(odo.body_velocity, [1.0, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(odo.twist_covariance.reshape(6, 6).diagonal()[:3],
                               [0.1, 0.5, 0.2], rtol=1e-6)
