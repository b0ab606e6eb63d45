"""The ENU/FLU <-> NED/FRD message builders: axes, covariances and a round trip."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import interfaces
from flight_control.frames import (
    frd_to_flu,
    ned_to_enu,
    quat_angle_between,
    quat_conjugate,
    quat_from_euler,
    quat_ned_frd_to_enu_flu,
    quat_rotate,
    variance_ned_to_enu,
    wrap_pi,
    yaw_ned_to_enu,
    yaw_rate_ned_to_enu,
)
from flight_control.px4_messages import (
    odometry_enu,
    offboard_control_mode,
    trajectory_setpoint,
    vision_odometry,
)
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


_NAN = [math.nan] * 3


def test_setpoint_axes_follow_enu_to_ned() -> None:
    # 1 m east, 2 m north, 3 m up -> 2 north, 1 east, -3 down; the same for each term
    msg = trajectory_setpoint([1.0, 2.0, 3.0], [0.1, 0.2, 0.3], [-1.0, -2.0, -3.0], 0.0, 0.5,
                              timestamp_us=42)
    np.testing.assert_allclose(msg.position, [2.0, 1.0, -3.0])
    np.testing.assert_allclose(msg.velocity, [0.2, 0.1, -0.3], rtol=1e-6)
    np.testing.assert_allclose(msg.acceleration, [-2.0, -1.0, 3.0])
    assert np.all(np.isnan(msg.jerk))
    assert msg.timestamp == 42


def test_setpoint_yaw_east_is_ned_half_pi_and_yaw_rate_flips() -> None:
    east = trajectory_setpoint(_NAN, _NAN, _NAN, 0.0, 0.5, timestamp_us=0)
    north = trajectory_setpoint(_NAN, _NAN, _NAN, math.pi / 2, 0.0, timestamp_us=0)
    assert math.isclose(east.yaw, math.pi / 2, abs_tol=1e-6)  # ENU 0 faces east
    assert math.isclose(north.yaw, 0.0, abs_tol=1e-6)  # ENU pi/2 faces north
    assert math.isclose(east.yawspeed, -0.5, rel_tol=1e-6)  # about Up -> about Down


def test_nan_axes_stay_nan_and_leave_their_term_uncontrolled() -> None:
    msg = trajectory_setpoint([1.0, math.nan, 3.0], _NAN, [0.0, 0.0, math.nan], math.nan,
                              math.nan, timestamp_us=7)
    # ENU y (north) NaN -> NED x NaN; ENU z (up) NaN -> NED z NaN
    assert np.isnan(msg.position[0]) and not np.isnan(msg.position[1:]).any()
    assert np.all(np.isnan(msg.velocity))
    assert np.isnan(msg.acceleration[2]) and not np.isnan(msg.acceleration[:2]).any()
    assert math.isnan(msg.yaw) and math.isnan(msg.yawspeed)
    mode = offboard_control_mode(msg, timestamp_us=7)
    assert (mode.position, mode.velocity, mode.acceleration) == (True, False, True)
    assert mode.timestamp == 7


def test_offboard_mode_of_a_horizontal_velocity_setpoint() -> None:
    # one finite axis is enough to control the term: the vertical speed here is left free
    msg = trajectory_setpoint(_NAN, [1.0, 0.0, math.nan], _NAN, math.nan, 0.0, timestamp_us=0)
    mode = offboard_control_mode(msg, timestamp_us=0)
    assert (mode.position, mode.velocity, mode.acceleration) == (False, True, False)


vec = st.lists(st.one_of(coord, st.just(math.nan)), min_size=3, max_size=3)


@given(p=vec, v=vec, a=vec, yaw=st.one_of(angle, st.just(math.nan)),
       yaw_rate=st.floats(-5.0, 5.0, allow_nan=False))
def test_setpoint_converted_back_gives_the_enu_inputs(p: list[float], v: list[float],
                                                      a: list[float], yaw: float,
                                                      yaw_rate: float) -> None:
    msg = trajectory_setpoint(p, v, a, yaw, yaw_rate, timestamp_us=0)
    wire = interfaces.deserialize(
        interfaces.serialize(msg, "px4_msgs/msg/TrajectorySetpoint"),
        "px4_msgs/msg/TrajectorySetpoint")
    for sent, got in ((p, wire.position), (v, wire.velocity), (a, wire.acceleration)):
        np.testing.assert_allclose(ned_to_enu(np.asarray(got, dtype=np.float64)), sent,
                                   atol=1e-5, equal_nan=True)
    if math.isnan(yaw):
        assert math.isnan(wire.yaw)
    else:
        assert abs(wrap_pi(yaw_ned_to_enu(float(wire.yaw)) - yaw)) < 1e-5
    assert math.isclose(yaw_rate_ned_to_enu(float(wire.yawspeed)), yaw_rate, abs_tol=1e-6)


quat_part = st.floats(-1.0, 1.0, allow_nan=False)


@given(p=st.lists(coord, min_size=3, max_size=3), v=st.lists(coord, min_size=3, max_size=3),
       w=st.lists(coord, min_size=3, max_size=3),
       q=st.lists(quat_part, min_size=4, max_size=4).filter(
           lambda q: sum(c * c for c in q) > 1e-3),
       var=st.lists(variance, min_size=9, max_size=9))
def test_odometry_on_floats_matches_the_frames_helpers(p: list[float], v: list[float],
                                                       w: list[float], q: list[float],
                                                       var: list[float]) -> None:
    # odometry_enu runs on floats for speed; the broadcasting frames helpers define it
    msg = interfaces.new("px4_msgs/msg/VehicleOdometry", position=p, velocity=v,
                         angular_velocity=w, q=q, position_variance=var[:3],
                         orientation_variance=var[3:6], velocity_variance=var[6:])
    odo = odometry_enu(msg)
    q_enu = quat_ned_frd_to_enu_flu(msg.q.astype(np.float64))
    velocity = ned_to_enu(msg.velocity.astype(np.float64))
    np.testing.assert_allclose(odo.q, q_enu, atol=1e-12)
    np.testing.assert_allclose(odo.position, ned_to_enu(msg.position.astype(np.float64)),
                               atol=1e-12)
    np.testing.assert_allclose(odo.velocity, velocity, atol=1e-12)
    np.testing.assert_allclose(odo.body_velocity,
                               quat_rotate(quat_conjugate(q_enu), velocity), atol=1e-9)
    np.testing.assert_allclose(odo.angular_velocity,
                               frd_to_flu(msg.angular_velocity.astype(np.float64)), atol=1e-12)
    pose = odo.pose_covariance.reshape(6, 6).diagonal()
    np.testing.assert_allclose(pose[:3], variance_ned_to_enu(msg.position_variance), rtol=1e-7)
    np.testing.assert_allclose(pose[3:], msg.orientation_variance, rtol=1e-7)
    np.testing.assert_allclose(odo.twist_covariance.reshape(6, 6).diagonal()[:3],
                               variance_ned_to_enu(msg.velocity_variance), rtol=1e-7)
    assert np.count_nonzero(odo.pose_covariance) == 6
