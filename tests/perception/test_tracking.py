"""Marker tracking between frames (perception/tracking.py) and the scanner's region and
smallest-side search it rests on (perception/aruco.py), on real rendered frames."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from perception.aruco import (
    ArucoScanner,
    Preprocess,
    ScanMode,
    ScannerSettings,
    grey_percentiles,
    side_px,
    stretch,
    to_grey,
)
from perception.tracking import RegionTracker, TrackerSettings, search_region

MISSION_PASSES = ScannerSettings(passes=(Preprocess.NONE, Preprocess.STRETCH))


def _frames_over_pad(lighting, positions):
    from sim.arena import default_arena
    from sim.camera_model import CameraSensorModel, camera_model_params
    from sim.render import SceneRenderer
    from sim.scene import place_quadrotor
    from sim.world import Scene

    arena = replace(default_arena(), lighting=lighting)
    scene = Scene.build(arena)
    sensor = CameraSensorModel(camera_model_params(), lighting, 0)
    x, y = arena.pad(2).center
    frames = []
    with SceneRenderer(scene.model) as renderer:
        for dx, dy, h in positions:
            place_quadrotor(scene.model, scene.data, scene.index, (x + dx, y + dy, h))
            frames.append(to_grey(sensor.apply(renderer.down_image(scene.data))))
    return frames


# a slow descent over pad 2 with a little drift, as a landing flies it (12 Hz frames)
DESCENT = [(0.15 * np.sin(k / 6.0), 0.1 * np.cos(k / 8.0), 1.8 - 0.03 * k) for k in range(16)]


@pytest.fixture(scope="module", params=["light", "dark"])
def descent(request):
    from sim.arena import Lighting

    return _frames_over_pad(Lighting(request.param), DESCENT)


def test_the_tracker_reads_what_the_whole_frame_gives(descent):
    # the floor the node sets at this height: whole frames and regions are searched halved,
    # and each marker's corners refined on the full image
    scanner = ArucoScanner(MISSION_PASSES)
    tracker = RegionTracker(scanner, min_side_px=60.0)
    for frame in descent:
        whole = scanner.find(frame, min_side_px=60.0)
        tracked = tracker.find(frame)
        assert tracked.keys() == whole.keys() == {2}
        np.testing.assert_allclose(tracked[2], whole[2], atol=0.1)
    # most frames were answered from the pad's region, a whole search every 4th at least
    assert tracker.tracked_frames >= len(descent) // 2
    assert tracker.full_frames >= len(descent) // 4


def test_a_whole_frame_search_comes_every_nth_frame_for_newcomers(descent):
    tracker = RegionTracker(ArucoScanner(MISSION_PASSES), TrackerSettings(full_frame_interval=3))
    whole = []
    for frame in descent:
        before = tracker.full_frames
        tracker.find(frame)
        whole.append(tracker.full_frames > before)
    # never more than two tracked frames in a row
    assert "".join("W" if w else "t" for w in whole).find("ttt") == -1
    assert whole[0]  # nothing tracked yet


def test_interval_one_searches_every_whole_frame(descent):
    tracker = RegionTracker(ArucoScanner(MISSION_PASSES), TrackerSettings(full_frame_interval=1))
    for frame in descent[:4]:
        tracker.find(frame)
    assert (tracker.full_frames, tracker.tracked_frames) == (4, 0)


def test_a_marker_lost_in_its_region_sends_the_frame_to_a_whole_search():
    from sim.arena import Lighting

    # over the pad, then 1.2 m aside: the pad jumps out of its region (and the frame)
    near, far = _frames_over_pad(Lighting.LIGHT, [(0.0, 0.0, 1.5), (1.2, 0.0, 1.5)])
    tracker = RegionTracker(ArucoScanner(MISSION_PASSES))
    assert set(tracker.find(near)) == {2}
    searched = tracker.full_frames
    assert 2 not in tracker.find(far)
    assert tracker.full_frames == searched + 1


def test_the_mode_filters_tracked_markers(descent):
    tracker = RegionTracker(ArucoScanner(MISSION_PASSES))
    assert set(tracker.find(descent[0], ScanMode.PADS)) == {2}
    assert tracker.find(descent[1], ScanMode.ROBOTS) == {}


def test_a_region_search_gives_whole_image_corners(descent):
    scanner = ArucoScanner(MISSION_PASSES)
    whole = scanner.find(descent[3])[2]
    region = search_region(whole, descent[3].shape, 0.5, 40)
    x0, y0, x1, y1 = region
    assert x0 <= whole[:, 0].min() and whole[:, 0].max() < x1
    assert y0 <= whole[:, 1].min() and whole[:, 1].max() < y1
    inside = scanner.find(descent[3], wanted=[2], region=region)
    np.testing.assert_allclose(inside[2], whole, atol=0.1)


def test_a_region_elsewhere_finds_nothing(descent):
    scanner = ArucoScanner(MISSION_PASSES)
    corners = scanner.find(descent[0])[2]
    right_of_it = (int(corners[:, 0].max()) + 5, 0, descent[0].shape[1], descent[0].shape[0])
    assert scanner.find(descent[0], region=right_of_it) == {}


def test_a_large_smallest_side_searches_halved_and_measures_as_the_full_image(request,
                                                                             descent):
    """From ``half_res_min_side_px`` on, the passes run on the image halved and the
    corners are refined on the full image: the same marker, within 0.35 px of the
    full-resolution corners, and the pad's offset from the camera within 3 mm of the truth
    (the descent's known positions), as the full-resolution search's."""
    from perception.aruco import measure
    from sim.render import CameraIntrinsics

    camera = CameraIntrinsics.from_fovy(640, 480, np.radians(60.0)).matrix()
    full = ArucoScanner(replace(MISSION_PASSES, half_res_min_side_px=0.0))
    halved = ArucoScanner(MISSION_PASSES)
    for frame, (dx, dy, _) in zip(descent, DESCENT, strict=True):
        a, b = full.find(frame, min_side_px=60.0), halved.find(frame, min_side_px=60.0)
        assert a.keys() == b.keys() == {2}
        np.testing.assert_allclose(b[2], a[2], atol=0.35)
        for corners in (a[2], b[2]):
            offset = measure(2, corners, camera, 0.5).offset_body
            np.testing.assert_allclose(offset, (-dx, -dy), atol=0.003)
    assert (full.searches_halved, halved.searches_halved) == (0, len(DESCENT))


def test_the_smallest_side_bound_skips_smaller_markers(descent):
    scanner = ArucoScanner(MISSION_PASSES)
    side = side_px(scanner.find(descent[0])[2])
    assert set(scanner.find(descent[0], min_side_px=0.8 * side)) == {2}
    assert scanner.find(descent[0], min_side_px=1.3 * side) == {}


@pytest.mark.parametrize("region", [(0, 0, 0, 10), (-1, 0, 10, 10), (0, 0, 641, 480),
                                    (10, 20, 5, 30)])
def test_a_region_outside_the_image_is_refused(region):
    with pytest.raises(ValueError, match="not inside the 640x480 image"):
        ArucoScanner().find(np.zeros((480, 640), np.uint8), region=region)


def test_search_region_grows_the_box_and_clips_to_the_image():
    corners = np.array([[100.0, 100.0], [140.0, 100.0], [140.0, 140.0], [100.0, 140.0]])
    assert search_region(corners, (480, 640), 0.5, 10) == (80, 80, 161, 161)
    assert search_region(corners, (480, 640), 0.5, 30) == (70, 70, 171, 171)
    assert search_region(corners - 90.0, (480, 640), 0.5, 30) == (0, 0, 81, 81)
    assert search_region(corners + [480.0, 320.0], (480, 640, 3), 0.5, 30) == (550, 390, 640, 480)


@pytest.mark.parametrize("kwargs, match", [({"full_frame_interval": 0}, "full_frame_interval"),
                                           ({"margin": -0.1}, "margin"),
                                           ({"margin_min_px": -1}, "margin_min_px"),
                                           ({"shrink": 0.0}, "shrink")])
def test_tracker_settings_name_the_bad_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        TrackerSettings(**kwargs)


@settings(max_examples=200, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 40), st.integers(1, 40))))
def test_the_histogram_percentiles_and_stretch_are_numpys(grey):
    lo, hi = np.percentile(grey, (1.0, 99.5))
    assert grey_percentiles(grey, (1.0, 99.5)) == pytest.approx([lo, hi], abs=1e-9)
    scale = 255.0 / max(float(hi - lo), 1.0)
    expected = np.clip((grey.astype(np.float32) - float(lo)) * scale, 0, 255).astype(np.uint8)
    np.testing.assert_array_equal(stretch(grey), expected)


def test_a_crop_is_stretched_by_the_whole_images_levels():
    grey = np.tile(np.arange(256, dtype=np.uint8) // 2, (4, 1))  # levels 0..127
    part = grey[:, :10]
    np.testing.assert_array_equal(stretch(grey, part), stretch(grey)[:, :10])
    assert stretch(grey, part).max() < stretch(part).max()


def test_the_search_is_halved_from_the_threshold_on_and_not_below_it(descent):
    scanner = ArucoScanner(MISSION_PASSES)
    threshold = MISSION_PASSES.half_res_min_side_px
    assert scanner.find(descent[0], min_side_px=threshold - 0.1).keys() == {2}
    assert scanner.searches_halved == 0
    assert scanner.find(descent[0], min_side_px=threshold).keys() == {2}
    assert scanner.searches_halved == 1
