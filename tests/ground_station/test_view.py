"""ground_station/view.py and the node's message helpers: what the page is fed."""

from __future__ import annotations

import math

import cv2
import numpy as np

import interfaces
from ground_station.gcs_node import cloud_xyz, image_rgb, jpeg, yaw_of
from ground_station.view import OperatorView, Pose2, RobotPicture


def test_flown_path_keeps_points_spaced_and_skips_invalid_positions() -> None:
    view = OperatorView(path_spacing_m=0.5, path_max_points=3)
    view.on_pose(0.0, Pose2(9.0, 9.0, 0.0, 0.0), flown=False)  # before the FCU's estimate
    for i in range(10):
        view.on_pose(0.1 * i, Pose2(0.2 * i, 0.0, 1.0, 0.0))
    snap = view.snapshot()
    # 0, 0.6, 1.2, 1.8 m are 0.5 m apart or more; only the last 3 are kept
    assert snap["flown"] == [[0.6, 0.0], [1.2, 0.0], [1.8, 0.0]]
    assert snap["pose"] == {"x": 1.8, "y": 0.0, "z": 1.0, "yaw": 0.0}
    assert snap["revision"] == 11 and snap["t_s"] == 0.9


def test_a_later_sighting_without_a_picture_keeps_the_first_picture() -> None:
    view = OperatorView()
    view.on_robot(1.0, RobotPicture(14, 3.0, 4.0, 1, b"jpeg"))
    view.on_robot(2.0, RobotPicture(14, 3.1, 4.1, 5, None))
    assert view.robot_jpeg(14) == b"jpeg"
    assert view.snapshot()["robots"] == [{"marker_id": 14, "x": 3.1, "y": 4.1, "sightings": 5,
                                          "picture": True}]


def test_yaw_of_a_quaternion_about_z() -> None:
    for yaw in (-2.5, 0.0, 0.7, 3.0):
        q = interfaces.new("geometry_msgs/msg/Quaternion", z=math.sin(yaw / 2),
                           w=math.cos(yaw / 2))
        assert math.isclose(yaw_of(q), yaw, abs_tol=1e-12)


def test_images_decode_by_encoding_and_scale_down_to_a_jpeg() -> None:
    rgb = np.zeros((4, 6, 3), dtype=np.uint8)
    rgb[:, :, 0] = 200  # red
    msg = interfaces.new("sensor_msgs/msg/Image", height=4, width=6, encoding="rgb8", step=18,
                         data=rgb.reshape(-1))
    assert np.array_equal(image_rgb(msg), rgb)
    bgr = interfaces.new("sensor_msgs/msg/Image", height=4, width=6, encoding="bgr8", step=18,
                         data=rgb[:, :, ::-1].reshape(-1).copy())
    assert np.array_equal(image_rgb(bgr), rgb)
    assert image_rgb(interfaces.new("sensor_msgs/msg/Image", height=4, width=6,
                                    encoding="32FC1", step=24)) is None
    big = np.full((480, 640, 3), 120, dtype=np.uint8)
    decoded = cv2.imdecode(np.frombuffer(jpeg(big, 320, 80), np.uint8), cv2.IMREAD_COLOR)
    assert decoded.shape == (240, 320, 3)


def test_cloud_points_are_read_from_their_field_offsets_and_thinned() -> None:
    points = np.array([[i, 2 * i, 0.5, 7.0] for i in range(10)], dtype=np.float32)
    fields = [interfaces.new("sensor_msgs/msg/PointField", name=n, offset=o, datatype=7,
                             count=1) for n, o in (("x", 0), ("y", 4), ("z", 8), ("i", 12))]
    msg = interfaces.new("sensor_msgs/msg/PointCloud2", height=1, width=10, fields=fields,
                         point_step=16, row_step=160, data=points.view(np.uint8).reshape(-1))
    assert cloud_xyz(msg, 100) == [(float(i), 2.0 * i, 0.5) for i in range(10)]
    assert cloud_xyz(msg, 5) == [(float(i), 2.0 * i, 0.5) for i in range(0, 10, 2)]


def test_images_and_clouds_whose_sizes_do_not_add_up_are_skipped() -> None:
    short = interfaces.new("sensor_msgs/msg/Image", height=4, width=6, encoding="rgb8",
                           step=18, data=np.zeros(40, dtype=np.uint8))
    assert image_rgb(short) is None
    narrow = interfaces.new("sensor_msgs/msg/Image", height=4, width=6, encoding="rgb8",
                            step=12, data=np.zeros(48, dtype=np.uint8))
    assert image_rgb(narrow) is None
    fields = [interfaces.new("sensor_msgs/msg/PointField", name=n, offset=o, datatype=7,
                             count=1) for n, o in (("x", 0), ("y", 4), ("z", 8))]
    cloud = interfaces.new("sensor_msgs/msg/PointCloud2", height=1, width=10, fields=fields,
                           point_step=12, row_step=120, data=np.zeros(100, dtype=np.uint8))
    assert cloud_xyz(cloud, 100) == []
    overlapping = interfaces.new("sensor_msgs/msg/PointCloud2", height=1, width=2,
                                 fields=fields, point_step=8, row_step=16,
                                 data=np.zeros(16, dtype=np.uint8))
    assert cloud_xyz(overlapping, 100) == []
