"""The scanner node through its topics: rendered frames in, markers out with the capture
stamp; a robot marker out as robot_found with its map position (from the pose at the
capture stamp) and decodable pictures; the mode whitelist; the enable service; health."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import interfaces
from interfaces import graph
from perception.aruco import ScanMode
from perception.aruco_scanner_node import ArucoScannerNode
from runtime import DeterministicExecutor, Node, Time, qos_profile_default, qos_profile_sensor_data
from sim.sensors import DOWN_FRAME, camera_info_msg, image_msg

MARKER: Any = interfaces.get_message("quadmission_interfaces/msg/MarkerDetection")


class _Camera(Node):
    """Publishes given frames as the down camera would, and listens to the scanner."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("test_camera", **kwargs)
        self.image = self.create_publisher("sensor_msgs/msg/Image", graph.CAMERA_DOWN_RAW.name,
                                           qos_profile_sensor_data)
        self.info = self.create_publisher("sensor_msgs/msg/CameraInfo", graph.CAMERA_DOWN_INFO.name,
                                          qos_profile_sensor_data)
        self.markers: list[Any] = []
        self.health: list[Any] = []
        self.create_subscription("quadmission_interfaces/msg/MarkerDetectionArray",
                                 graph.PERCEPTION_MARKERS.name, self.markers.append,
                                 qos_profile_default)
        self.create_subscription("quadmission_interfaces/msg/HealthReport",
                                 "/aruco_scanner/health", self.health.append,
                                 qos_profile_default)
        self.enable = self.create_client(interfaces.get_service("std_srvs/srv/SetBool"),
                                         "/aruco_scanner/enable")
        self.odometry = self.create_publisher("nav_msgs/msg/Odometry", "/fcu/odometry",
                                              qos_profile_sensor_data)

    def height(self, z: float) -> None:
        """The odometry says the vehicle is ``z`` [m] above the map's floor."""
        self.odometry.publish(interfaces.new(
            "nav_msgs/msg/Odometry", header=interfaces.new("std_msgs/msg/Header"),
            pose=interfaces.new("geometry_msgs/msg/PoseWithCovariance", pose=interfaces.new(
                "geometry_msgs/msg/Pose", position=interfaces.new("geometry_msgs/msg/Point",
                                                                  z=z)))))

    def send(self, frame: np.ndarray, intrinsics: Any, stamp_ns: int) -> None:
        stamp = Time(stamp_ns)
        self.info.publish(camera_info_msg(intrinsics, stamp, DOWN_FRAME))
        self.image.publish(image_msg(frame, stamp, DOWN_FRAME))


@pytest.fixture(scope="module")
def frames():
    from sim.arena import default_arena
    from sim.render import CameraIntrinsics, SceneRenderer
    from sim.scene import place_quadrotor, set_robot_poses
    from sim.world import Scene

    arena = default_arena()
    scene = Scene.build(arena)
    set_robot_poses(scene.data, scene.index, arena, 0.0)
    with SceneRenderer(scene.model) as renderer:
        x, y = arena.pad(4).center
        place_quadrotor(scene.model, scene.data, scene.index, (x - 0.3, y, 1.5))
        pad = renderer.down_image(scene.data)
        rx, ry = arena.robots[0].path[0]
        place_quadrotor(scene.model, scene.data, scene.index, (rx, ry, 1.6))
        robot = renderer.down_image(scene.data)
    return {"intrinsics": CameraIntrinsics.from_camera(scene.quad.down_camera), "pad": pad,
            "robot": robot, "robot_id": arena.robots[0].marker_id, "robot_xy": (rx, ry)}


def _rig(**overrides: Any) -> tuple[DeterministicExecutor, _Camera, ArucoScannerNode]:
    ex = DeterministicExecutor()
    scanner = ArucoScannerNode(context=ex.context, parameter_overrides=overrides)
    camera = _Camera(context=ex.context)
    ex.add_node(scanner)
    ex.add_node(camera)
    ex.spin_for(0.05)
    return ex, camera, scanner


def test_markers_carry_the_capture_stamp_kind_and_offset(frames):
    ex, camera, _ = _rig()
    stamp_ns = 1_234_567_890
    camera.send(frames["pad"], frames["intrinsics"], stamp_ns)
    ex.spin_for(0.1)
    (msg,) = camera.markers
    assert Time.from_msg(msg.header.stamp).nanoseconds == stamp_ns
    (d,) = msg.detections
    assert Time.from_msg(d.header.stamp).nanoseconds == stamp_ns
    assert (d.id, d.kind) == (4, MARKER.KIND_PAD)
    # the vehicle heads east (yaw 0) 0.3 m west of the pad: the pad is 0.3 m ahead
    assert d.offset_x == pytest.approx(0.3, abs=0.01)
    assert d.offset_y == pytest.approx(0.0, abs=0.01)
    assert d.height == pytest.approx(1.5 - 0.06 - 0.01, abs=0.02)


def test_opencv_threads_sets_the_process_pool_and_the_same_markers_come_out(frames):
    import cv2

    before = cv2.getNumThreads()
    try:
        found = {}
        for threads in (2, 1):
            ex, camera, _ = _rig(opencv_threads=threads)
            assert cv2.getNumThreads() == threads
            camera.send(frames["pad"], frames["intrinsics"], 100_000_000)
            ex.spin_for(0.1)
            (msg,) = camera.markers
            found[threads] = [(d.id, d.corners_px.tolist()) for d in msg.detections]
        assert found[1] == found[2] and found[1]  # the pool's size changes no result
        cv2.setNumThreads(before)
        _rig(opencv_threads=0)  # 0 leaves the pool as it is
        assert cv2.getNumThreads() == before
    finally:
        cv2.setNumThreads(before)


def test_mode_robots_ignores_pads_and_reports_the_robot(frames):
    ex, camera, _ = _rig(mode="robots")
    camera.send(frames["pad"], frames["intrinsics"], 100_000_000)
    ex.spin_for(0.1)
    camera.send(frames["robot"], frames["intrinsics"], 200_000_000)
    ex.spin_for(0.1)
    assert [len(m.detections) for m in camera.markers] == [0, 1]
    d = camera.markers[1].detections[0]
    assert (d.id, d.kind) == (frames["robot_id"], MARKER.KIND_ROBOT)


def test_the_vehicles_height_sets_the_smallest_marker_searched(frames):
    """The robot's 0.4 m marker, 1.3 m below the camera, is ~128 px. An odometry that says
    the vehicle is 0.1 m up (farthest marker 0.6 m) makes the floor 166 px: not searched.
    At its true height it is found; with the odometry stale, the max_range_m floor."""
    ex, camera, scanner = _rig(mode="robots")
    t = 0
    for z, seen in ((0.1, False), (1.6, True), (None, True)):
        if z is not None:
            camera.height(z)
            ex.spin_for(0.01)
        else:
            ex.spin_for(0.6)  # no odometry for longer than its timeout
        t += 1_000_000_000
        camera.send(frames["robot"], frames["intrinsics"], t)
        ex.spin_for(0.1)
        assert bool(camera.markers[-1].detections) is seen, z
    fy = frames["intrinsics"].fy
    assert scanner.tracker.min_side_px == pytest.approx(
        scanner.params.min_side_px(ScanMode.ROBOTS, fy))  # stale: max_range_m's floor


def test_disabled_it_publishes_nothing_and_says_so(frames):
    ex, camera, scanner = _rig()
    future = camera.enable.call_async(interfaces.new("std_srvs/srv/SetBool_Request", data=False))
    ex.spin_for(0.05)
    assert future.result().success and not scanner.enabled
    camera.send(frames["pad"], frames["intrinsics"], 100_000_000)
    ex.spin_for(1.1)
    assert camera.markers == []
    assert camera.health[-1].modules[0].message == "disabled"


def test_disabled_it_leaves_the_image_topic_so_the_camera_renders_nothing(frames):
    """The down camera renders only while someone subscribes: a disabled scanner is not on
    the topic, and on again it is, scans the next frame, and its health stays OK meanwhile."""
    ex, camera, scanner = _rig()
    assert camera.image.get_subscription_count() == 1
    camera.send(frames["pad"], frames["intrinsics"], 10_000_000)  # the intrinsics known
    ex.spin_for(0.1)
    request = "std_srvs/srv/SetBool_Request"
    camera.enable.call_async(interfaces.new(request, data=False))
    ex.spin_for(3.0)  # longer than image_timeout_s with no image: no error while off
    assert camera.image.get_subscription_count() == 0
    assert camera.health[-1].level == 0 and camera.health[-1].modules[0].message == "disabled"
    camera.enable.call_async(interfaces.new(request, data=True))
    ex.spin_for(2.1)  # past image_timeout_s with no frame yet: within the grace, still OK
    assert scanner.enabled and camera.image.get_subscription_count() == 1
    assert camera.health[-1].level == 0, camera.health[-1].modules[0].message
    camera.send(frames["pad"], frames["intrinsics"], 5_000_000_000)
    ex.spin_for(1.1)
    assert [d.id for d in camera.markers[-1].detections] == [4]
    assert camera.health[-1].level == 0, camera.health[-1].modules[0].message


def test_health_reports_a_missing_camera():
    ex, camera, _ = _rig()
    ex.spin_for(2.1)
    assert camera.health[-1].level == 2  # ERROR
    assert "no image" in camera.health[-1].modules[0].message


class _Fcu(Node):
    """Answers ``/fcu/pose_at`` (the bridge's contract) with the pose each frame was
    rendered from, and records the stamps it was asked for."""

    def __init__(self, poses_by_stamp: dict[int, tuple[float, float, float]],
                 **kwargs: Any) -> None:
        super().__init__("test_fcu", **kwargs)
        self.poses = poses_by_stamp
        self.asked: list[int] = []
        self.create_service(interfaces.get_service("quadmission_interfaces/srv/PoseAt"),
                            "/fcu/pose_at", self._on)

    def _on(self, request: Any, response: Any) -> Any:
        stamp_ns = Time.from_msg(request.stamp).nanoseconds
        self.asked.append(stamp_ns)
        if stamp_ns not in self.poses:
            response.success, response.message = False, "no pose at that time"
            return response
        x, y, z = self.poses[stamp_ns]
        response.success = True
        p = response.odometry.pose.pose
        p.position.x, p.position.y, p.position.z = x, y, z
        p.orientation.w = 1.0  # the frames are rendered heading east (yaw 0)
        return response


def _decode_jpeg(picture: Any) -> np.ndarray:
    import cv2

    assert picture.format == "jpeg"
    bgr = cv2.imdecode(np.asarray(picture.data, dtype=np.uint8), cv2.IMREAD_COLOR)
    assert bgr is not None, "the picture is not a decodable JPEG"
    return np.asarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))


def test_a_robot_marker_yields_robot_found_with_its_map_position_and_pictures(frames):
    from perception.aruco import ArucoScanner, ScanMode

    ex, camera, _ = _rig(mode="robots")
    stamp_ns = 2_500_000_000
    rx, ry = frames["robot_xy"]
    fcu = _Fcu({stamp_ns: (rx, ry, 1.6)}, context=ex.context)
    ex.add_node(fcu)
    found: list[Any] = []
    camera.create_subscription("quadmission_interfaces/msg/RobotFound",
                               graph.PERCEPTION_ROBOT_FOUND.name, found.append,
                               qos_profile_default)
    ex.spin_for(0.05)
    camera.send(frames["pad"], frames["intrinsics"], stamp_ns - 100_000_000)  # no robot
    camera.send(frames["robot"], frames["intrinsics"], stamp_ns)
    ex.spin_for(0.2)
    assert fcu.asked == [stamp_ns]  # the pose of the capture instant, nothing else
    (msg,) = found
    assert msg.marker_id == frames["robot_id"]
    assert Time.from_msg(msg.header.stamp).nanoseconds == stamp_ns
    assert msg.header.frame_id == "map"
    # the marker lies on the robot right below the camera: its map position is the robot's
    assert (msg.pose.position.x, msg.pose.position.y) == pytest.approx((rx, ry), abs=0.03)
    assert msg.sightings == 1
    raw = _decode_jpeg(msg.picture_raw)
    annotated = _decode_jpeg(msg.picture_annotated)
    assert raw.shape == annotated.shape == frames["robot"].shape
    # the raw picture is the frame as captured: the marker still decodes from it
    assert set(ArucoScanner().find(raw, ScanMode.ROBOTS)) == {frames["robot_id"]}
    # the annotated one outlines the marker: orange (255, 64, 0) on its corners
    ((corners,),) = [ArucoScanner().find(frames["robot"], ScanMode.ROBOTS).values()]
    for u, v in np.round(corners).astype(int):
        patch = annotated[v - 2:v + 3, u - 2:u + 3].reshape(-1, 3).astype(int)
        assert any(r > 180 and b < 90 for r, _, b in patch), f"no outline at ({u}, {v})"
        raw_patch = raw[v - 2:v + 3, u - 2:u + 3].reshape(-1, 3).astype(int)
        assert not any(r > 180 and b < 90 for r, _, b in raw_patch)
