"""perception/aruco.py: eq. 1 and eq. 2, the metric offset and height, and detection on
frames rendered by the simulator (the real OpenCV, the real renderer)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception.aruco import (
    ArucoScanner,
    MarkerKind,
    ScanMode,
    ScannerSettings,
    body_offset,
    camera_to_body,
    camera_to_body_frd,
    marker_center,
    measure,
)

K = np.array([[415.69, 0.0, 319.5], [0.0, 415.69, 239.5], [0.0, 0.0, 1.0]])
SIDES = {MarkerKind.PAD: 0.5, MarkerKind.ROBOT: 0.4}


def _line_intersection(p1, p3, p2, p4):
    """The diagonals' intersection by solving p1 + s (p3 - p1) = p2 + t (p4 - p2)."""
    a = np.column_stack([p3 - p1, -(p4 - p2)])
    s, _ = np.linalg.solve(a, p2 - p1)
    return p1 + s * (p3 - p1)


def test_eq1_centre_of_a_square_is_its_middle():
    corners = [[10, 10], [30, 10], [30, 30], [10, 30]]
    assert marker_center(corners) == pytest.approx([20.0, 20.0])


def test_eq1_differs_from_the_corner_mean_under_perspective():
    # a trapezoid (a square seen at a slant): the diagonals cross off the corner mean
    corners = np.array([[0.0, 0.0], [10.0, 0.0], [14.0, 10.0], [-4.0, 10.0]])
    centre = marker_center(corners)
    assert centre == pytest.approx(_line_intersection(*corners[[0, 2, 1, 3]]))
    assert abs(centre[1] - corners[:, 1].mean()) > 0.5


quads = st.lists(st.floats(-1000, 1000, allow_nan=False), min_size=8, max_size=8).map(
    lambda v: np.array(v).reshape(4, 2))


@given(quads)
def test_eq1_is_the_intersection_of_the_diagonals(corners):
    d13, d24 = corners[2] - corners[0], corners[3] - corners[1]
    det = d13[0] * d24[1] - d13[1] * d24[0]
    scale = np.linalg.norm(d13) * np.linalg.norm(d24)
    if abs(det) < 1e-3 * max(scale, 1.0):  # (near) parallel diagonals: no single point
        return
    expected = _line_intersection(corners[0], corners[2], corners[1], corners[3])
    assert marker_center(corners) == pytest.approx(expected, abs=1e-6 * max(1.0, scale))


def test_eq1_refuses_parallel_diagonals():
    with pytest.raises(ValueError, match="parallel"):
        marker_center([[0, 0], [1, 0], [2, 0], [3, 0]])


def test_eq2_flu_is_the_seeds_frd_with_y_flipped():
    # marker up and to the right in the image: ahead and to the right of the vehicle
    ev = np.array([12.0, -30.0])  # e_x^v right, e_y^v up (negative: v grows down)
    frd = camera_to_body_frd(ev)
    flu = camera_to_body(ev)
    assert frd == pytest.approx([30.0, 12.0])  # forward, right
    assert flu == pytest.approx([frd[0], -frd[1]])  # forward, left


def test_body_offset_by_the_pinhole_model():
    # a point 0.2 m ahead and 0.1 m to the left, 1.5 m below: where it projects
    u = K[0, 2] + (-0.1) * K[0, 0] / 1.5  # left = -x_optical
    v = K[1, 2] + (-0.2) * K[1, 1] / 1.5  # forward = -y_optical (image up)
    assert body_offset([u, v], 1.5, K) == pytest.approx([0.2, 0.1])


def _project_square(side, t, yaw):
    h = side / 2
    obj = np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]])
    r = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                  [0, 0, 1]])
    pts = (r @ obj.T).T + t
    uv = (K @ pts.T).T
    return uv[:, :2] / uv[:, 2:]


def test_measure_recovers_height_and_offset_from_the_marker_size():
    t = np.array([0.15, -0.25, 1.2])  # optical: 0.15 m right, 0.25 m image-up (ahead), 1.2 m
    m = measure(3, _project_square(0.5, t, 0.4), K, 0.5)
    assert m.height == pytest.approx(1.2, abs=1e-6)
    assert m.offset_body == pytest.approx([0.25, -0.15], abs=1e-6)  # ahead, right
    assert m.kind is MarkerKind.PAD
    assert m.reprojection_error_px < 1e-6


@pytest.fixture(scope="module")
def rendered():
    """Frames of the contest arena from the down camera: over pad 2 and over robot 14."""
    from sim.arena import default_arena
    from sim.render import CameraIntrinsics, SceneRenderer
    from sim.scene import place_quadrotor, set_robot_poses
    from sim.world import Scene

    arena = default_arena()
    scene = Scene.build(arena)
    set_robot_poses(scene.data, scene.index, arena, 0.0)
    robot = arena.robots[0]
    out = {"K": CameraIntrinsics.from_camera(scene.quad.down_camera).matrix()}
    with SceneRenderer(scene.model) as renderer:
        x, y = arena.pad(2).center
        place_quadrotor(scene.model, scene.data, scene.index, (x + 0.2, y - 0.1, 1.5), yaw=0.3)
        out["pad"] = renderer.down_image(scene.data)
        rx, ry = robot.path[0]
        place_quadrotor(scene.model, scene.data, scene.index, (rx, ry, 1.6))
        out["robot"] = renderer.down_image(scene.data)
        out["robot_id"] = robot.marker_id
    return out


def test_a_rendered_pad_is_found_where_it_is(rendered):
    (m,) = ArucoScanner().detect(rendered["pad"], rendered["K"], SIDES, ScanMode.PADS)
    assert m.id == 2 and m.kind is MarkerKind.PAD
    # the pad is 0.2 m west and 0.1 m north of the vehicle, which heads 0.3 rad
    c, s = math.cos(0.3), math.sin(0.3)
    expected = [c * -0.2 + s * 0.1, -s * -0.2 + c * 0.1]
    assert m.offset_body == pytest.approx(expected, abs=0.01)
    assert m.height == pytest.approx(1.5 - 0.06 - 0.01, abs=0.02)


def test_eq1_centre_matches_the_corner_mean_on_a_flat_view(rendered):
    (m,) = ArucoScanner().detect(rendered["pad"], rendered["K"], SIDES)
    assert m.center_px == pytest.approx(m.corners_px.mean(axis=0), abs=0.5)


def test_the_mode_whitelist_keeps_pads_from_robots(rendered):
    scanner = ArucoScanner()
    assert [m.id for m in scanner.detect(rendered["robot"], rendered["K"], SIDES,
                                         ScanMode.ROBOTS)] == [rendered["robot_id"]]
    assert scanner.detect(rendered["robot"], rendered["K"], SIDES, ScanMode.PADS) == []
    assert scanner.detect(rendered["pad"], rendered["K"], SIDES, ScanMode.ROBOTS) == []


def test_a_12_px_marker_needs_the_small_pass():
    """Table 1's hardest cell: 3.5 cm at 1.2 m, 1.3 px per module, in the light."""
    from dataclasses import replace as _replace

    from sim.arena import Lighting, default_arena
    from sim.marker_board import marker_board_scene, view_from_above
    from sim.render import SceneRenderer

    arena = _replace(default_arena(), lighting=Lighting.LIGHT)
    scene = marker_board_scene(arena, 5, 0.035, (2.0, 10.0))
    hits = {"defaults": 0, "ours": 0}
    with SceneRenderer(scene.model) as renderer:
        for yaw in np.linspace(-3.0, 3.0, 6):
            view_from_above(scene, 1.2, yaw=float(yaw))
            frame = renderer.down_image(scene.data)
            hits["defaults"] += set(ArucoScanner(ScannerSettings.opencv_defaults()).find(
                frame)) == {5}
            hits["ours"] += set(ArucoScanner().find(frame, wanted=[5])) == {5}
    assert hits["ours"] == 6
    assert hits["defaults"] < 6


def _marker_image(marker_id: int, angle_deg: float) -> np.ndarray:
    import cv2

    from perception.aruco import _dictionary

    img = np.full((300, 300), 255, np.uint8)
    img[100:190, 100:190] = _dictionary().generateImageMarker(marker_id, 90, borderBits=1)
    turn = cv2.getRotationMatrix2D((145.0, 145.0), angle_deg, 1.0)
    return np.asarray(cv2.warpAffine(img, turn, (300, 300), borderValue=255))


@pytest.mark.parametrize("angle_deg", [0.0, 35.0, 100.0, 250.0])
@pytest.mark.parametrize("roll", [0, 1, 2, 3])
def test_small_decoding_names_the_marker_and_opencv_corner_order(angle_deg, roll):
    """decode_small on a quad given from any corner: the right ID, and the corners in
    OpenCV's order (the marker's top-left first) whichever corner the quad started at."""
    import cv2

    from perception.aruco import _dictionary, decode_small

    image = _marker_image(7, angle_deg)
    detector = cv2.aruco.ArucoDetector(_dictionary(), cv2.aruco.DetectorParameters())
    corners, ids, _ = detector.detectMarkers(image)
    assert ids is not None and ids.ravel().tolist() == [7]
    opencv = corners[0].reshape(4, 2).astype(np.float64)
    hit = decode_small(image.astype(np.float32), np.roll(opencv, roll, axis=0), (3, 7, 12))
    assert hit is not None and hit.id == 7
    assert hit.correlation > 0.95 and hit.margin > 0.3
    assert hit.corners_px == pytest.approx(opencv, abs=1.0)


def test_small_decoding_rejects_a_square_that_is_no_whitelisted_marker():
    """A dark square with a pattern of another ID (999, not whitelisted) falls below the
    scanner's acceptance thresholds for the contest's IDs."""
    import cv2

    from perception.aruco import PAD_IDS, ROBOT_IDS, _dictionary, decode_small

    image = _marker_image(999, 20.0)
    detector = cv2.aruco.ArucoDetector(_dictionary(), cv2.aruco.DetectorParameters())
    corners, _, _ = detector.detectMarkers(image)
    settings = ScannerSettings()
    hit = decode_small(image.astype(np.float32), corners[0].reshape(4, 2),
                       tuple(sorted(PAD_IDS | ROBOT_IDS)))
    assert hit is not None
    assert hit.correlation < settings.small_min_correlation or \
        hit.margin < settings.small_min_margin


def test_a_corner_outside_the_image_is_kept_as_found_and_the_others_refined() -> None:
    # The small-marker path doubles a crop's corners (2c + 0.5): a marker cut by the
    # frame's edge can get a corner past it, for which cv2.cornerSubPix raises ("initial
    # corner is outside the image"); a dark random arena lost a whole mission to it.
    from perception.aruco import _refined

    grey = np.zeros((60, 80), dtype=np.uint8)
    grey[20:40, 30:50] = 255  # a white square, corners at (29.5, 19.5)...(49.5, 39.5)
    near = np.array([[31.0, 21.0], [48.0, 21.0], [48.0, 38.0], [31.0, 38.0]])
    cut = np.array([[70.0, 10.0], [80.2, 10.0], [80.2, 20.0], [70.0, 20.0]])  # x >= w
    out = _refined(grey, {7: near, 9: cut})
    np.testing.assert_allclose(out[9][1:3], cut[1:3], atol=1e-5)  # nothing to refine on: as found
    assert np.abs(out[7] - [[29.5, 19.5], [49.5, 19.5], [49.5, 39.5], [29.5, 39.5]]).max() < 0.6
    assert np.abs(near - [[29.5, 19.5], [49.5, 19.5], [49.5, 39.5], [29.5, 39.5]]).max() > 1.4
