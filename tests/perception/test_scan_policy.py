"""perception/scan_policy.py: the scanner's decisions image by image, without the runtime:
which images are scanned, when an annotated image and a robot report are due, where a
robot is and how its sightings merge, what health reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.aruco import MarkerKind, ScanMode
from perception.params import MIN_SIDE_SAFETY, ScannerParams
from perception.scan_policy import (
    ODOMETRY_TIMEOUT_S,
    Problem,
    RobotTrack,
    ScanPolicy,
    marker_in_map,
    rotate,
)
from runtime.parameters import load_parameters

S = 1_000_000_000
ROBOT, PAD, OTHER = MarkerKind.ROBOT, MarkerKind.PAD, MarkerKind.OTHER


def _policy(**kw) -> ScanPolicy:
    settings = {"enabled": True, "mode": ScanMode.BOTH, "annotated_rate_hz": 2.0,
                "robot_report_interval_s": 1.0, "image_timeout_s": 1.0}
    settings.update(kw)
    return ScanPolicy(**settings)


def _q_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0))


# -- which images ----------------------------------------------------------------------------
def test_an_image_is_scanned_while_enabled_once_the_intrinsics_are_known():
    policy = _policy()
    assert policy.image(0, camera_known=True)
    assert not policy.image(1, camera_known=False)
    policy.enabled = False
    assert not policy.image(2, camera_known=True)


def test_the_mode_is_set_by_name_and_a_wrong_name_keeps_it():
    policy = _policy(mode=ScanMode.PADS)
    assert policy.mode is ScanMode.PADS
    assert policy.set_mode("robots") is None and policy.mode is ScanMode.ROBOTS
    assert policy.set_mode("cars") == "mode: 'cars' is not one of pads, robots, both"
    assert policy.mode is ScanMode.ROBOTS


# -- how far the farthest marker is ----------------------------------------------------------
def test_the_farthest_marker_is_the_fresh_height_plus_the_margin():
    policy = _policy(height_margin_m=0.5)
    assert policy.marker_range_m(0) is None  # no odometry yet
    policy.height(1 * S, 1.5)
    assert policy.marker_range_m(1 * S) == pytest.approx(2.0)
    assert policy.marker_range_m(1 * S + int(ODOMETRY_TIMEOUT_S * S)) == pytest.approx(2.0)
    assert policy.marker_range_m(1 * S + int(ODOMETRY_TIMEOUT_S * S) + 1) is None  # stale
    policy.height(3 * S, -0.1)  # landed a little below home: never a negative range
    assert policy.marker_range_m(3 * S) == pytest.approx(0.5)
    policy.height(4 * S, float("nan"))  # the estimate is invalid: the height is unknown
    assert policy.marker_range_m(4 * S) is None


def test_the_smallest_side_searched_follows_the_range_up_to_max_range():
    params = load_parameters(ScannerParams, "aruco_scanner")
    focal, robot = 415.7, params.robot_marker_size
    at_max = params.min_side_px(ScanMode.BOTH, focal)
    assert at_max == pytest.approx(MIN_SIDE_SAFETY * focal * robot / params.max_range_m)
    # 2 m away: the marker is bigger, so is the smallest outline searched
    assert params.min_side_px(ScanMode.BOTH, focal, 2.0) == pytest.approx(
        MIN_SIDE_SAFETY * focal * robot / 2.0)
    # a range beyond max_range_m is max_range_m; pads only: the pads' printed side
    assert params.min_side_px(ScanMode.BOTH, focal, 50.0) == pytest.approx(at_max)
    assert params.min_side_px(ScanMode.PADS, focal, 2.0) == pytest.approx(
        MIN_SIDE_SAFETY * focal * params.pad_marker_size / 2.0)


# -- counts, robot reports -------------------------------------------------------------------
def test_scanned_images_are_counted():
    policy = _policy()
    policy.scanned(0, [])
    policy.scanned(1, [(4, PAD), (13, ROBOT)])
    policy.scanned(2, [(5, PAD)])
    assert (policy.frames, policy.frames_with_markers, policy.detections) == (3, 2, 3)


def test_a_robot_is_reported_at_its_first_sighting_and_then_once_per_interval():
    policy = _policy(robot_report_interval_s=1.0)
    assert policy.scanned(0, [(4, PAD), (13, ROBOT), (7, OTHER)]) == [1]  # the robot only
    assert policy.robots[13].last_report_ns == 0
    assert policy.scanned(S // 2, [(13, ROBOT)]) == []  # within the interval
    assert policy.scanned(S - 1, [(13, ROBOT)]) == []
    assert policy.scanned(S, [(4, PAD), (13, ROBOT)]) == [1]  # a full interval later
    assert policy.robots[13].last_report_ns == S
    assert policy.scanned(S + 1, [(13, ROBOT)]) == []  # counted from the last report


def test_each_robot_has_its_own_interval():
    policy = _policy(robot_report_interval_s=1.0)
    assert policy.scanned(0, [(13, ROBOT)]) == [0]
    assert policy.scanned(S // 2, [(13, ROBOT), (20, ROBOT)]) == [1]
    assert policy.scanned(S, [(20, ROBOT), (13, ROBOT)]) == [1]
    assert sorted(policy.robots) == [13, 20]


def test_with_no_interval_every_sighting_is_reported():
    policy = _policy(robot_report_interval_s=0.0)
    assert policy.scanned(0, [(13, ROBOT)]) == [0]
    assert policy.scanned(0, [(13, ROBOT), (13, ROBOT)]) == [0, 1]


def test_pads_are_never_reported_nor_tracked():
    policy = _policy()
    assert policy.scanned(0, [(4, PAD), (5, PAD)]) == []
    assert policy.robots == {}


# -- annotated images ------------------------------------------------------------------------
def test_an_annotated_image_is_due_at_most_at_its_rate_and_only_for_listeners():
    policy = _policy(annotated_rate_hz=2.0)
    assert not policy.annotated_due(0, listeners=0)
    assert policy.annotated_due(1, listeners=1)  # the first at once
    assert not policy.annotated_due(S // 2, listeners=1)  # 0.5 s minus 1 ns after it
    assert policy.annotated_due(S // 2 + 1, listeners=2)
    assert not policy.annotated_due(S // 2 + 2, listeners=1)


def test_an_annotated_image_below_one_hertz():
    policy = _policy(annotated_rate_hz=0.5)
    assert policy.annotated_due(0, listeners=1)
    assert not policy.annotated_due(2 * S - 1, listeners=1)
    assert policy.annotated_due(2 * S, listeners=1)


def test_no_annotated_images_at_rate_zero():
    policy = _policy(annotated_rate_hz=0.0)
    assert not any(policy.annotated_due(t * S, listeners=1) for t in range(5))


# -- where a robot is ------------------------------------------------------------------------
def test_rotate_turns_a_vector_by_the_quaternion():
    assert rotate(_q_yaw(math.pi / 2), [1.0, 0.0, 0.5]) == pytest.approx([0.0, 1.0, 0.5])
    roll = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # 90 deg about x
    assert rotate(roll, [0.0, 1.0, 0.0]) == pytest.approx([0.0, 0.0, 1.0])


def test_a_single_precision_vector_is_rotated_in_double_precision():
    q = _q_yaw(0.7)
    v32 = np.array([0.1, -0.2, 1.3], dtype=np.float32)
    exact = rotate(q, v32.astype(np.float64))
    assert rotate(q, v32).dtype == np.float64
    assert np.array_equal(rotate(q, v32), exact)


def test_a_marker_straight_below_is_at_the_vehicles_xy():
    # optical frame: z along the view (down); 1.5 m below the camera, itself 0.06 m
    # below the body origin
    at = marker_in_map((2.0, 3.0, 1.6), _q_yaw(0.8), (0.0, 0.0, 1.5), (0.0, 0.0, -0.06))
    assert at == pytest.approx([2.0, 3.0, 1.6 - 0.06 - 1.5])


def test_a_marker_ahead_in_the_image_is_ahead_of_the_vehicle_in_the_map():
    # image up (optical -y) is body forward; heading north (yaw 90 deg): forward is +y
    at = marker_in_map((2.0, 3.0, 1.5), _q_yaw(math.pi / 2), (0.0, -0.4, 1.5),
                       (0.1, 0.0, 0.0))
    assert at == pytest.approx([2.0, 3.0 + 0.4 + 0.1, 0.0])
    # image right (optical +x) is body right (-y): heading north, that is +x
    at = marker_in_map((2.0, 3.0, 1.5), _q_yaw(math.pi / 2), (0.3, 0.0, 1.5),
                       (0.0, 0.0, 0.0))
    assert at == pytest.approx([2.3, 3.0, 0.0])


def test_a_robots_sightings_merge_into_their_mean_and_horizontal_spread():
    policy = _policy()
    sightings = np.array([[1.0, 2.0, 0.3], [1.2, 2.1, 0.1], [0.9, 1.7, 0.2], [1.1, 2.2, 0.4]])
    for i, p in enumerate(sightings, start=1):
        track = policy.sighting(13, p)
        assert track.sightings == i
        assert track.mean == pytest.approx(sightings[:i].mean(axis=0))
        expected_std = 0.0 if i == 1 else math.sqrt(
            sightings[:i, 0].var(ddof=1) + sightings[:i, 1].var(ddof=1))
        assert track.horizontal_std == pytest.approx(expected_std)
    assert policy.robots[13] is track


def test_a_sighting_is_not_aliased_into_the_track():
    track = RobotTrack()
    p = np.array([1.0, 2.0, 3.0])
    track.add(p)
    p[:] = 0.0
    assert track.mean == pytest.approx([1.0, 2.0, 3.0])


def test_a_track_without_sightings_has_no_spread():
    assert RobotTrack().horizontal_std == 0.0


# -- health ----------------------------------------------------------------------------------
def test_health_says_no_image_before_any_and_after_the_timeout():
    policy = _policy(image_timeout_s=1.0)
    assert policy.problems(0, camera_known=True) == [Problem.IMAGE_STALE]
    policy.image(5 * S, camera_known=True)
    assert policy.problems(6 * S, camera_known=True) == []  # 1 s: not more
    assert policy.problems(6 * S + 1, camera_known=True) == [Problem.IMAGE_STALE]


def test_health_says_no_camera_info():
    policy = _policy()
    policy.image(0, camera_known=False)  # an image without intrinsics still counts as one
    assert policy.problems(1, camera_known=False) == [Problem.NO_CAMERA_INFO]
    assert policy.problems(2 * S, camera_known=False) == [Problem.IMAGE_STALE,
                                                          Problem.NO_CAMERA_INFO]


def test_disabled_nothing_is_wrong():
    policy = _policy(enabled=False)
    assert policy.problems(10 * S, camera_known=False) == []


def test_switched_on_again_the_images_are_awaited_from_then():
    """Off for a while, the last image is long past; on again, that is not stale until
    image_timeout_s plus ENABLE_GRACE_S after the switch (the image topic is subscribed
    again: the camera's first frame is on its way); from the first image on, the plain
    timeout again."""
    from perception.scan_policy import ENABLE_GRACE_S

    policy = _policy(image_timeout_s=1.0)
    policy.image(0, camera_known=True)
    assert policy.enable(1 * S, False) and not policy.enabled
    assert not policy.enable(2 * S, False), "already off: nothing changed"
    assert policy.problems(30 * S, camera_known=True) == []
    assert policy.enable(30 * S, True) and policy.enabled
    due = 30 * S + int((1.0 + ENABLE_GRACE_S) * S)
    assert policy.problems(due, camera_known=True) == []
    assert policy.problems(due + 1, camera_known=True) == [Problem.IMAGE_STALE]
    policy.image(due + 2, camera_known=True)
    assert policy.problems(due + 2 + S, camera_known=True) == []
    assert policy.problems(due + 3 + S, camera_known=True) == [Problem.IMAGE_STALE]
