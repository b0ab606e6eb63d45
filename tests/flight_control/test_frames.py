"""flight_control.frames: known attitudes and headings in both conventions, agreement with
px4_ros_com frame_transforms, round trips and frame consistency as properties, NaN as
"not set" propagating without warnings, and the module staying pure numpy."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import interfaces
from flight_control import frames as fr

# every conversion must be silent on NaN / zero input: a warning here is a failure
pytestmark = pytest.mark.filterwarnings("error")

H = math.sqrt(0.5)
DEG = math.pi / 180.0
TOL = 1e-9

# --- strategies ------------------------------------------------------------------------

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
vec3 = hnp.arrays(np.float64, 3, elements=finite)
vecs = hnp.arrays(np.float64, st.tuples(st.integers(1, 8), st.just(3)), elements=finite)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
# keep clear of gimbal lock where only yaw -+ roll is defined
pitch_ok = st.floats(-math.pi / 2 + 1e-3, math.pi / 2 - 1e-3, allow_nan=False)


@st.composite
def unit_quats(draw: st.DrawFn) -> np.ndarray:
    raw = draw(hnp.arrays(np.float64, 4, elements=st.floats(-1.0, 1.0)))
    if np.linalg.norm(raw) < 0.1:
        raw = np.array([1.0, 0.0, 0.0, 0.0]) + raw  # still random, never near zero
    return raw / np.linalg.norm(raw)


def same_rotation(p: np.ndarray, q: np.ndarray, tol: float = 1e-9) -> bool:
    return bool(np.all(fr.quat_angle_between(p, q) < tol))


def angle_diff(a: float | np.ndarray, b: float | np.ndarray) -> np.ndarray:
    return np.abs(fr.wrap_pi(np.asarray(a, dtype=np.float64) - b))


# --- known cases: the picture a pilot has in mind --------------------------------------


def test_level_facing_north_faces_plus_y_in_enu() -> None:
    q_enu = fr.quat_ned_frd_to_enu_flu([1.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(q_enu, [H, 0.0, 0.0, H], atol=TOL)
    assert fr.quat_to_yaw(q_enu) == pytest.approx(math.pi / 2)
    # the nose (FLU +x) points North, which is ENU +y; up stays up
    np.testing.assert_allclose(fr.quat_rotate(q_enu, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=TOL)
    np.testing.assert_allclose(fr.quat_rotate(q_enu, [0.0, 0.0, 1.0]), [0.0, 0.0, 1.0], atol=TOL)


def test_facing_east_is_ned_yaw_half_pi_and_enu_yaw_zero() -> None:
    q_ned = fr.quat_from_yaw(math.pi / 2)
    np.testing.assert_allclose(fr.quat_rotate(q_ned, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=TOL)
    q_enu = fr.quat_ned_frd_to_enu_flu(q_ned)
    assert fr.quat_to_yaw(q_enu) == pytest.approx(0.0, abs=TOL)
    assert same_rotation(q_enu, np.array([1.0, 0.0, 0.0, 0.0]))
    assert fr.yaw_ned_to_enu(math.pi / 2) == pytest.approx(0.0, abs=TOL)


@pytest.mark.parametrize(
    ("heading", "yaw_ned", "yaw_enu"),
    [
        ("North", 0.0, math.pi / 2),
        ("East", math.pi / 2, 0.0),
        ("South", math.pi, -math.pi / 2),
        ("West", -math.pi / 2, math.pi),  # (-pi, pi]: pi, never -pi
        ("North-East", math.pi / 4, math.pi / 4),
        ("South-West", -3 * math.pi / 4, -3 * math.pi / 4),
        ("North-West", -math.pi / 4, 3 * math.pi / 4),
    ],
)
def test_compass_headings(heading: str, yaw_ned: float, yaw_enu: float) -> None:
    got = fr.yaw_ned_to_enu(yaw_ned)
    assert isinstance(got, float)
    assert got == pytest.approx(yaw_enu, abs=TOL), heading
    assert fr.yaw_enu_to_ned(yaw_enu) == pytest.approx(fr.wrap_pi(yaw_ned), abs=TOL), heading
    # and through the quaternions
    q_enu = fr.quat_ned_frd_to_enu_flu(fr.quat_from_yaw(yaw_ned))
    assert float(angle_diff(fr.quat_to_yaw(q_enu), yaw_enu)) < TOL, heading


def test_roll_right_is_roll_right_in_both_frames() -> None:
    q_ned = fr.quat_from_euler(10 * DEG, 0.0, 0.0)  # facing North, right wing down
    right_wing_ned = fr.quat_rotate(q_ned, [0.0, 1.0, 0.0])  # FRD +y
    assert right_wing_ned[2] > 0.0  # NED z is down
    q_enu = fr.quat_ned_frd_to_enu_flu(q_ned)
    right_wing_enu = fr.quat_rotate(q_enu, [0.0, -1.0, 0.0])  # FLU -y
    assert right_wing_enu[2] < 0.0  # ENU z is up
    np.testing.assert_allclose(fr.quat_to_euler(q_enu), [10 * DEG, 0.0, math.pi / 2], atol=TOL)


def test_nose_up_is_positive_pitch_in_frd_and_negative_in_flu() -> None:
    q_ned = fr.quat_from_euler(0.0, 10 * DEG, 0.0)
    assert fr.quat_rotate(q_ned, [1.0, 0.0, 0.0])[2] < 0.0  # nose above the horizon (NED)
    q_enu = fr.quat_ned_frd_to_enu_flu(q_ned)
    assert fr.quat_rotate(q_enu, [1.0, 0.0, 0.0])[2] > 0.0  # nose above the horizon (ENU)
    np.testing.assert_allclose(fr.quat_to_euler(q_enu), [0.0, -10 * DEG, math.pi / 2], atol=TOL)
    np.testing.assert_allclose(
        fr.euler_ned_frd_to_enu_flu([0.0, 10 * DEG, 0.0]), [0.0, -10 * DEG, math.pi / 2]
    )


def test_static_vectors() -> None:
    np.testing.assert_array_equal(fr.ned_to_enu([1.0, 2.0, 3.0]), [2.0, 1.0, -3.0])
    np.testing.assert_array_equal(fr.enu_to_ned([2.0, 1.0, -3.0]), [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(fr.frd_to_flu([1.0, 2.0, 3.0]), [1.0, -2.0, -3.0])
    np.testing.assert_array_equal(fr.flu_to_frd([1.0, -2.0, -3.0]), [1.0, 2.0, 3.0])
    # a climb at 1 m/s is vz = -1 in NED, +1 in ENU; yawing right is +r in FRD, -r in FLU
    assert fr.ned_to_enu([0.0, 0.0, -1.0])[2] == 1.0
    assert fr.frd_to_flu([0.0, 0.0, 0.5])[2] == -0.5
    assert fr.yaw_rate_ned_to_enu(0.5) == -0.5
    assert fr.yaw_rate_enu_to_ned(-0.5) == 0.5


def test_variances_and_covariances() -> None:
    np.testing.assert_array_equal(fr.variance_ned_to_enu([1.0, 2.0, 3.0]), [2.0, 1.0, 3.0])
    np.testing.assert_array_equal(fr.variance_enu_to_ned([2.0, 1.0, 3.0]), [1.0, 2.0, 3.0])
    cov = np.array([[1.0, 0.1, 0.2], [0.1, 2.0, 0.3], [0.2, 0.3, 3.0]])
    p_ned_enu = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    np.testing.assert_allclose(fr.covariance_ned_to_enu(cov), p_ned_enu @ cov @ p_ned_enu.T)
    np.testing.assert_allclose(fr.covariance_enu_to_ned(fr.covariance_ned_to_enu(cov)), cov)
    b = np.diag([1.0, -1.0, -1.0])
    np.testing.assert_allclose(fr.covariance_frd_to_flu(cov), b @ cov @ b.T)
    np.testing.assert_allclose(fr.covariance_flu_to_frd(fr.covariance_frd_to_flu(cov)), cov)
    # variances are the diagonals of the covariances
    np.testing.assert_allclose(
        np.diagonal(fr.covariance_ned_to_enu(cov)), fr.variance_ned_to_enu(np.diagonal(cov))
    )


def test_quaternion_field_orders() -> None:
    q = np.array([0.1, 0.2, 0.3, 0.4])  # [w, x, y, z]
    np.testing.assert_array_equal(fr.quat_to_xyzw(q), [0.2, 0.3, 0.4, 0.1])
    np.testing.assert_array_equal(fr.quat_from_xyzw(fr.quat_to_xyzw(q)), q)
    np.testing.assert_array_equal(fr.quat_to_xyzw(np.stack([q, q]))[1], [0.2, 0.3, 0.4, 0.1])


def test_hamilton_product_convention() -> None:
    # Hamilton: i * j = k, and composition applies the right-hand rotation first
    i, j, k = np.eye(4)[1], np.eye(4)[2], np.eye(4)[3]
    np.testing.assert_array_equal(fr.quat_multiply(i, j), k)
    q_a_b, q_b_c = fr.quat_from_yaw(0.3), fr.quat_from_euler(0.2, 0.0, 0.0)
    v_c = np.array([0.0, 1.0, 0.0])
    np.testing.assert_allclose(
        fr.quat_rotate(fr.quat_multiply(q_a_b, q_b_c), v_c),
        fr.quat_rotate(q_a_b, fr.quat_rotate(q_b_c, v_c)),
        atol=TOL,
    )
    r = fr.quat_to_rotation_matrix(fr.quat_from_yaw(math.pi / 2))
    np.testing.assert_allclose(r, [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=TOL)


def test_matches_px4_ros_com_formula_up_to_sign() -> None:
    """px4_to_ros_orientation(q) = NED_ENU_Q * q * AIRCRAFT_BASELINK_Q, with
    NED_ENU_Q = quaternion_from_euler(pi, 0, pi/2) and AIRCRAFT_BASELINK_Q =
    quaternion_from_euler(pi, 0, 0); ros_to_px4_orientation is the same expression."""
    ned_enu_q = fr.quat_from_euler(math.pi, 0.0, math.pi / 2)
    aircraft_baselink_q = fr.quat_from_euler(math.pi, 0.0, 0.0)
    np.testing.assert_allclose(ned_enu_q, [0.0, H, H, 0.0], atol=TOL)
    np.testing.assert_allclose(
        fr.quat_to_rotation_matrix(ned_enu_q), [[0, 1, 0], [1, 0, 0], [0, 0, -1]], atol=TOL
    )
    rng = np.random.default_rng(7)
    q = fr.quat_normalise(rng.normal(size=(32, 4)))
    theirs = fr.quat_multiply(fr.quat_multiply(ned_enu_q, q), aircraft_baselink_q)
    np.testing.assert_allclose(fr.quat_ned_frd_to_enu_flu(q), -theirs, atol=TOL)
    np.testing.assert_allclose(fr.quat_enu_flu_to_ned_frd(theirs), -q, atol=TOL)


def test_gimbal_lock_euler_still_gives_the_rotation() -> None:
    for pitch in (math.pi / 2, -math.pi / 2):
        q = fr.quat_from_euler(0.3, pitch, 1.0)
        rpy = fr.quat_to_euler(q)
        assert rpy[0] == 0.0
        assert rpy[1] == pytest.approx(pitch)
        assert same_rotation(fr.quat_from_euler(*rpy), q)
        assert float(fr.quat_to_yaw(q)) == rpy[2]


def test_rotation_matrix_known_and_half_turns() -> None:
    # half turns are where a naive trace-based conversion divides by zero
    for q in ([0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, H, H, 0]):
        assert same_rotation(
            fr.quat_from_rotation_matrix(fr.quat_to_rotation_matrix(q)), np.array(q)
        )


def test_px4_messages_go_through() -> None:
    """float32 message arrays in, float64 out; a setpoint's NaN stays "not set"."""
    q_ned = fr.quat_from_euler(5 * DEG, -3 * DEG, 120 * DEG).astype(np.float32)
    odom = interfaces.new(
        "px4_msgs/msg/VehicleOdometry",
        position=[1.0, 2.0, -3.0],
        q=q_ned.tolist(),
        velocity=[0.5, -0.5, 0.1],
        angular_velocity=[0.01, 0.02, 0.03],
        position_variance=[0.1, 0.2, 0.3],
    )
    np.testing.assert_allclose(fr.ned_to_enu(odom.position), [2.0, 1.0, 3.0])
    q_enu = fr.quat_ned_frd_to_enu_flu(odom.q)
    assert q_enu.dtype == np.float64
    expected_yaw = fr.yaw_ned_to_enu(120 * DEG)
    assert float(angle_diff(fr.quat_to_yaw(q_enu), expected_yaw)) < 1e-6
    np.testing.assert_allclose(
        fr.frd_to_flu(odom.angular_velocity), [0.01, -0.02, -0.03], rtol=1e-6
    )
    np.testing.assert_allclose(
        fr.variance_ned_to_enu(odom.position_variance), [0.2, 0.1, 0.3], rtol=1e-6
    )

    sp_enu = np.array([np.nan, np.nan, 1.5])  # hold altitude 1.5 m, xy not controlled
    sp = interfaces.new(
        "px4_msgs/msg/TrajectorySetpoint",
        position=fr.enu_to_ned(sp_enu).astype(np.float32),
        yaw=fr.yaw_enu_to_ned(math.pi / 2),
    )
    interfaces.validate(sp)
    assert np.isnan(sp.position[:2]).all()
    assert sp.position[2] == pytest.approx(-1.5)
    assert sp.yaw == pytest.approx(0.0)


# --- NaN: PX4's "not set" ------------------------------------------------------------


def test_nan_stays_in_its_component() -> None:
    nan = math.nan
    np.testing.assert_array_equal(fr.ned_to_enu([nan, 2.0, 3.0]), [2.0, nan, -3.0])
    np.testing.assert_array_equal(fr.enu_to_ned([1.0, 2.0, nan]), [2.0, 1.0, nan])
    np.testing.assert_array_equal(fr.frd_to_flu([1.0, nan, 3.0]), [1.0, nan, -3.0])
    np.testing.assert_array_equal(fr.flu_to_frd([nan, 2.0, 3.0]), [nan, -2.0, -3.0])
    np.testing.assert_array_equal(fr.variance_ned_to_enu([nan, 2.0, 3.0]), [2.0, nan, 3.0])
    cov = np.eye(3)
    cov[0, 2] = cov[2, 0] = nan
    out = fr.covariance_ned_to_enu(cov)
    assert np.isnan(out).sum() == 2
    assert np.isnan(out[1, 2]) and np.isnan(out[2, 1])
    # rows are independent in a batch
    batch = fr.ned_to_enu([[nan, nan, -5.0], [1.0, 2.0, 3.0]])
    np.testing.assert_array_equal(batch, [[nan, nan, 5.0], [2.0, 1.0, -3.0]])


def test_nan_angles_and_rates() -> None:
    assert math.isnan(fr.yaw_ned_to_enu(math.nan))
    assert math.isnan(fr.yaw_enu_to_ned(np.float32(np.nan)))
    assert math.isnan(fr.yaw_rate_ned_to_enu(math.nan))
    assert math.isnan(fr.wrap_pi(math.inf))
    out = fr.yaw_ned_to_enu(np.array([0.0, np.nan]))
    assert out[0] == pytest.approx(math.pi / 2)
    assert np.isnan(out[1])
    np.testing.assert_array_equal(
        np.isnan(fr.euler_ned_frd_to_enu_flu([0.1, np.nan, 0.2])), [False, True, False]
    )


def test_invalid_quaternions_become_all_nan() -> None:
    # PX4 marks an invalid attitude with q[0] = NaN; a zero quaternion is no rotation at all
    for bad in ([math.nan, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [math.inf, 0.0, 0.0, 0.0]):
        assert np.isnan(fr.quat_normalise(bad)).all()
        assert np.isnan(fr.quat_rotate(bad, [1.0, 0.0, 0.0])).all()
        assert np.isnan(fr.quat_to_euler(bad)).all()
        assert np.isnan(fr.quat_to_rotation_matrix(bad)).all()
        assert math.isnan(fr.quat_to_yaw(bad))
    assert np.isnan(fr.quat_ned_frd_to_enu_flu([math.nan, 0.0, 0.0, 0.0])).all()
    matrix = np.eye(3)
    matrix[1, 2] = math.nan
    assert np.isnan(fr.quat_from_rotation_matrix(matrix)).all()
    # one bad row does not spoil its neighbours
    good = fr.quat_normalise([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(good[0], [1.0, 0.0, 0.0, 0.0])


# --- shapes ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "arg"),
    [
        (fr.ned_to_enu, [1.0, 2.0]),
        (fr.frd_to_flu, 1.0),
        (fr.quat_normalise, [1.0, 0.0, 0.0]),
        (fr.quat_from_rotation_matrix, np.eye(4)),
        (fr.covariance_ned_to_enu, [1.0, 2.0, 3.0]),
    ],
)
def test_wrong_shape_is_a_value_error_naming_the_shape(call: object, arg: object) -> None:
    with pytest.raises(ValueError, match="expected shape"):
        call(arg)  # type: ignore[operator]


@given(vecs)
def test_batches_equal_row_by_row(v: np.ndarray) -> None:
    for convert in (fr.ned_to_enu, fr.enu_to_ned, fr.frd_to_flu, fr.flu_to_frd):
        batch = convert(v)
        assert batch.shape == v.shape
        for row_in, row_out in zip(v, batch, strict=True):
            np.testing.assert_array_equal(convert(row_in), row_out)


# --- properties ------------------------------------------------------------------------


@given(vec3)
def test_world_and_body_round_trips_are_exact(v: np.ndarray) -> None:
    np.testing.assert_array_equal(fr.enu_to_ned(fr.ned_to_enu(v)), v)
    np.testing.assert_array_equal(fr.ned_to_enu(fr.enu_to_ned(v)), v)
    np.testing.assert_array_equal(fr.flu_to_frd(fr.frd_to_flu(v)), v)
    np.testing.assert_array_equal(fr.variance_enu_to_ned(fr.variance_ned_to_enu(v)), v)


@given(unit_quats())
def test_attitude_round_trip(q: np.ndarray) -> None:
    q_enu = fr.quat_ned_frd_to_enu_flu(q)
    np.testing.assert_allclose(np.linalg.norm(q_enu), 1.0, atol=TOL)
    np.testing.assert_allclose(fr.quat_enu_flu_to_ned_frd(q_enu), q, atol=TOL)
    np.testing.assert_allclose(
        fr.quat_ned_frd_to_enu_flu(fr.quat_enu_flu_to_ned_frd(q)), q, atol=TOL
    )


@given(unit_quats(), vec3)
def test_rotating_then_converting_equals_converting_then_rotating(
    q_ned_frd: np.ndarray, v_frd: np.ndarray
) -> None:
    """The defining property of the attitude conversion: a body vector seen in the world
    is the same physical vector whichever side of the bridge does the rotation."""
    via_ned = fr.ned_to_enu(fr.quat_rotate(q_ned_frd, v_frd))
    via_flu = fr.quat_rotate(fr.quat_ned_frd_to_enu_flu(q_ned_frd), fr.frd_to_flu(v_frd))
    np.testing.assert_allclose(via_flu, via_ned, atol=1e-9 * (1.0 + float(np.linalg.norm(v_frd))))


@given(unit_quats())
def test_yaw_of_converted_attitude_is_converted_yaw(q: np.ndarray) -> None:
    yaw_enu = fr.quat_to_yaw(fr.quat_ned_frd_to_enu_flu(q))
    # yaw is ill-conditioned near pitch +/-90 deg (its atan2 arguments both go to 0): the
    # round-off there grows as 1 / cos(pitch), so the bound does too
    pitch = float(fr.quat_to_euler(q)[1])
    bound = 1e-9 / max(abs(np.cos(pitch)), 1e-6)
    assert float(angle_diff(yaw_enu, fr.yaw_ned_to_enu(float(fr.quat_to_yaw(q))))) < bound


@given(angle, pitch_ok, angle)
def test_euler_round_trip(roll: float, pitch: float, yaw: float) -> None:
    rpy = fr.quat_to_euler(fr.quat_from_euler(roll, pitch, yaw))
    assert np.all(angle_diff(rpy, np.array([roll, pitch, yaw])) < 1e-8)


@given(angle, pitch_ok, angle)
def test_euler_conversion_agrees_with_quaternion_conversion(
    roll: float, pitch: float, yaw: float
) -> None:
    q_enu = fr.quat_ned_frd_to_enu_flu(fr.quat_from_euler(roll, pitch, yaw))
    expected = fr.euler_ned_frd_to_enu_flu([roll, pitch, yaw])
    assert np.all(angle_diff(fr.quat_to_euler(q_enu), expected) < 1e-8)
    back = fr.euler_enu_flu_to_ned_frd(expected)
    assert np.all(angle_diff(back, np.array([roll, pitch, yaw])) < 1e-9)


@given(unit_quats())
def test_quaternion_to_euler_to_quaternion_is_the_same_rotation(q: np.ndarray) -> None:
    assert same_rotation(fr.quat_from_euler(*fr.quat_to_euler(q)), q, tol=1e-7)


@given(unit_quats())
def test_rotation_matrix_round_trip(q: np.ndarray) -> None:
    r = fr.quat_to_rotation_matrix(q)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=TOL)
    assert np.linalg.det(r) == pytest.approx(1.0)
    back = fr.quat_from_rotation_matrix(r)
    assert back[0] >= 0.0
    assert same_rotation(back, q)  # exactly +-q; at w == 0 both signs are canonical
    assert np.abs(back - q).max() < 1e-9 or np.abs(back + q).max() < 1e-9


@given(unit_quats(), vec3)
def test_rotation_matches_matrix_and_conjugate_inverts(q: np.ndarray, v: np.ndarray) -> None:
    scale = 1.0 + float(np.linalg.norm(v))
    rotated = fr.quat_rotate(q, v)
    np.testing.assert_allclose(rotated, fr.quat_to_rotation_matrix(q) @ v, atol=1e-9 * scale)
    np.testing.assert_allclose(fr.quat_rotate(fr.quat_conjugate(q), rotated), v, atol=1e-9 * scale)
    # a non-unit quaternion (float32 message, scaled) is the same rotation
    np.testing.assert_allclose(fr.quat_rotate(3.0 * q, v), rotated, atol=1e-9 * scale)


@given(angle)
def test_yaw_round_trip_and_range(yaw: float) -> None:
    enu = fr.yaw_ned_to_enu(yaw)
    assert -math.pi < enu <= math.pi
    assert float(angle_diff(fr.yaw_enu_to_ned(enu), yaw)) < 1e-12
    assert float(angle_diff(fr.quat_to_yaw(fr.quat_from_yaw(yaw)), yaw)) < 1e-12


@given(st.floats(-1.4, 1.4), st.floats(-1.4, 1.4), angle)
def test_a_tilt_does_not_change_the_heading(roll: float, pitch: float, yaw: float) -> None:
    """The heading the scanner and the ground station read (:func:`quat_to_yaw_f`) is the
    yaw alone, whatever the roll and pitch under it."""
    q = fr.quat_from_euler(roll, pitch, yaw).tolist()
    assert float(angle_diff(fr.quat_to_yaw_f(q), yaw)) < 1e-9


@given(angle, pitch_ok, angle)
def test_closed_form_euler_angles_are_quat_to_eulers(roll: float, pitch: float,
                                                     yaw: float) -> None:
    """Precision landing's closed form (:func:`quat_to_yaw_roll_pitch`) reads the angles
    in :func:`quat_to_euler`'s convention, only ordered yaw, roll, pitch."""
    q = fr.quat_from_euler(roll, pitch, yaw)
    got = fr.quat_to_yaw_roll_pitch(q.tolist())
    want_roll, want_pitch, want_yaw = fr.quat_to_euler(q).tolist()
    # round-off in roll and yaw grows as 1 / cos(pitch) towards gimbal lock
    bound = 1e-9 / max(math.cos(pitch), 1e-6)
    assert float(angle_diff(got[0], want_yaw)) < bound
    assert float(angle_diff(got[1], want_roll)) < bound
    assert float(angle_diff(got[2], want_pitch)) < 1e-9
    assert float(angle_diff(got[2], pitch)) < 1e-7


@pytest.mark.parametrize(("rpy", "yaw_roll_pitch"), [
    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.5), (0.5, 0.0, 0.0)),  # heading, counter-clockwise from above
    ((0.3, 0.0, 0.0), (0.0, 0.3, 0.0)),  # roll about the body x axis
    ((0.0, -0.2, 0.0), (0.0, 0.0, -0.2)),  # pitch about the body y axis
    ((0.1, 0.2, 3.0), (3.0, 0.1, 0.2)),
])
def test_closed_form_euler_angles_of_known_attitudes(
        rpy: tuple[float, float, float], yaw_roll_pitch: tuple[float, float, float]) -> None:
    got = fr.quat_to_yaw_roll_pitch(fr.quat_from_euler(*rpy).tolist())
    assert got == pytest.approx(yaw_roll_pitch, abs=1e-12)


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_wrap_pi_range_and_equivalence(a: float) -> None:
    w = fr.wrap_pi(a)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)


# --- the float versions: the same bits as the array versions --------------------------

# any quaternion, not only unit ones: zero, NaN and tiny components included
some_quat = hnp.arrays(np.float64, 4, elements=st.one_of(
    finite, st.sampled_from([0.0, -0.0, 1e-200, math.nan])))
vec3_or_nan = hnp.arrays(np.float64, 3, elements=st.one_of(finite, st.just(math.nan)))


def same_bits(got: tuple[float, ...] | float, want: np.ndarray) -> None:
    """Equal to the last bit (-0.0 == 0.0; NaN matches NaN of either sign)."""
    np.testing.assert_array_equal(np.asarray(got, dtype=np.float64), want, strict=True)


@given(some_quat, some_quat)
def test_quaternion_algebra_on_floats_is_bit_identical(p: np.ndarray, q: np.ndarray) -> None:
    pf, qf = p.tolist(), q.tolist()
    same_bits(fr.quat_multiply_f(pf, qf), fr.quat_multiply(p, q))
    same_bits(fr.quat_normalise_f(qf), fr.quat_normalise(q))
    same_bits(fr.quat_conjugate_f(qf), fr.quat_conjugate(q))
    same_bits(fr.quat_ned_frd_to_enu_flu_f(qf), fr.quat_ned_frd_to_enu_flu(q))
    same_bits(fr.quat_enu_flu_to_ned_frd_f(qf), fr.quat_enu_flu_to_ned_frd(q))


@given(some_quat, vec3_or_nan)
def test_rotation_and_yaw_on_floats_are_bit_identical(q: np.ndarray, v: np.ndarray) -> None:
    same_bits(fr.quat_rotate_f(q.tolist(), v.tolist()), fr.quat_rotate(q, v))
    same_bits(fr.quat_to_yaw_f(q.tolist()), fr.quat_to_yaw(q))


@pytest.mark.parametrize("pitch", [math.pi / 2, -math.pi / 2])
def test_yaw_on_floats_at_gimbal_lock(pitch: float) -> None:
    q = fr.quat_from_euler(0.4, pitch, -1.1)
    same_bits(fr.quat_to_yaw_f(q.tolist()), fr.quat_to_yaw(q))


@given(vec3_or_nan)
def test_static_frame_changes_on_floats_are_bit_identical(v: np.ndarray) -> None:
    vf = v.tolist()
    same_bits(fr.ned_to_enu_f(vf), fr.ned_to_enu(v))
    same_bits(fr.enu_to_ned_f(vf), fr.enu_to_ned(v))
    same_bits(fr.frd_to_flu_f(vf), fr.frd_to_flu(v))
    same_bits(fr.variance_ned_to_enu_f(vf), fr.variance_ned_to_enu(v))
    same_bits(fr.variance_enu_to_ned_f(vf), fr.variance_enu_to_ned(v))


@pytest.mark.parametrize(
    ("call", "args"),
    [
        (fr.ned_to_enu_f, ([1.0, 2.0],)),
        (fr.frd_to_flu_f, (1.0,)),
        (fr.quat_normalise_f, ([1.0, 0.0, 0.0],)),
        (fr.quat_rotate_f, ([1.0, 0.0, 0.0, 0.0], [1.0, 2.0, 3.0, 4.0])),
        (fr.quat_enu_flu_to_ned_frd_f, ([1.0] * 5,)),
    ],
)
def test_floats_of_the_wrong_length_are_a_value_error_naming_the_shape(
        call: object, args: tuple[object, ...]) -> None:
    with pytest.raises(ValueError, match="expected shape"):
        call(*args)  # type: ignore[operator]


@given(st.one_of(st.floats(-1e6, 1e6), st.sampled_from(
    [math.nan, math.inf, -math.inf, -1e-17, 1e-17, math.pi, -math.pi, 3 * math.pi])))
def test_scalar_wrap_pi_is_the_array_wrap_pi(a: float) -> None:
    got = fr.wrap_pi(a)
    assert type(got) is float
    same_bits(got, fr.wrap_pi(np.array(a)))
    same_bits(fr.wrap_pi(np.float64(a)), fr.wrap_pi(np.array(a)))


# --- purity ----------------------------------------------------------------------------


def test_module_imports_numpy_only() -> None:
    """STYLE 1: the algorithm module never imports the runtime or the message layer."""
    tree = ast.parse(Path(fr.__file__).read_text())
    imported = {
        name.split(".")[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.Import | ast.ImportFrom)
        for name in (
            [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
        )
    }
    assert imported <= {"__future__", "collections", "math", "typing", "numpy"}, imported
