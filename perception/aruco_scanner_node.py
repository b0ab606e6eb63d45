"""The ArUco scanner node (seed 003 sec. 3.3.1): markers on the downward camera.

Subscribes to ``/camera/down/image_raw`` and ``/camera/down/camera_info``, and to
``/fcu/odometry`` for the vehicle's height: a whole-frame search skips outlines smaller
than the smallest marker seen from there (the noise's small outlines are what a search
spends its time on; at the cruise height the search runs on the image halved). For each
image while enabled it runs :class:`perception.aruco.ArucoScanner` and publishes (what is
due when, and where a robot is: :class:`perception.scan_policy.ScanPolicy`, pure):

- ``/perception/markers`` (MarkerDetectionArray): every accepted marker with its ID,
  kind (pad/robot), eq. 1 centre, body-frame offset [m], height [m] and pose, stamped
  with the **image capture time** (an empty array when none was seen, so a listener
  knows the frame was looked at);
- ``~/annotated`` (sensor_msgs/Image, at most ``annotated_rate_hz``) for people;
- ``/perception/robot_found`` (RobotFound) when a robot marker is seen: its ID, its
  map position from ``/fcu/pose_at`` at the capture time, and JPEG pictures (the frame
  as captured and annotated), at most once per ``robot_report_interval_s`` per robot;
- ``~/health`` (HealthReport): camera stale, disabled, frames and detections.

``~/enable`` (std_srvs/SetBool, ``interfaces.graph.SCANNER_ENABLE``) switches scanning on
and off; off, the node also leaves the image topic, so a camera that renders only for its
subscribers renders nothing (the mission switches it off where no phase reads markers). The
``mode`` parameter (pads, robots, both) chooses the ID whitelist and can be set at run time.
Parameters: ``config/aruco_scanner.yaml`` (:class:`perception.params.ScannerParams`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np

import interfaces
from flight_control.frames import quat_to_yaw_f
from flight_control.health import health_report
from interfaces import graph
from perception.aruco import ArucoScanner, Marker, annotate, measure_all
from perception.messages import detection_msg, jpeg_msg
from perception.params import ScannerParams
from perception.scan_policy import Problem, ScanPolicy, marker_in_map
from perception.tracking import RegionTracker
from runtime import Node, Parameter, Time
from runtime.parameters import SetParametersResult

NODE_NAME = "aruco_scanner"
IMAGE, INFO = graph.CAMERA_DOWN_RAW, graph.CAMERA_DOWN_INFO
POSE_AT_RETRIES = 5  # a frame is processed when captured; the odometry of that instant
POSE_AT_RETRY_S = 0.02  # s, comes over the link a few ms later: ask again this often
MAP_FRAME = "map"

HEALTH: Any = interfaces.get_message("quadmission_interfaces/msg/ModuleHealth")
SET_BOOL = graph.SCANNER_ENABLE.interface()
POSE_AT = graph.POSE_AT.interface()
_PROBLEM_TEXT = {Problem.IMAGE_STALE: f"no image on {IMAGE.name}",
                 Problem.NO_CAMERA_INFO: f"no {INFO.name}"}


class ArucoScannerNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(ScannerParams)
        if self.params.opencv_threads > 0:  # OpenCV's pool is the process's, as in C++
            cv2.setNumThreads(self.params.opencv_threads)
        self.policy = ScanPolicy(
            enabled=self.params.enabled, mode=self.params.mode,
            annotated_rate_hz=self.params.annotated_rate_hz,
            robot_report_interval_s=self.params.robot_report_interval_s,
            image_timeout_s=self.params.image_timeout_s,
            height_margin_m=self.params.height_margin_m)
        self.tracker = RegionTracker(ArucoScanner(self.params.scanner_settings()),
                                     self.params.tracker_settings())
        self.camera: np.ndarray | None = None  # K, from camera_info
        self._scanning = False  # a frame's scan is under way (offloaded)
        self._waiting: Any = None  # the newest image that came meanwhile, scanned next
        self.frames_dropped = 0  # images replaced by a newer one while they waited
        self.markers_pub, self.robot_pub, self.annotated_pub, self.health_pub = (
            self.create_publisher(t.type, t.name, t.qos)
            for t in (graph.PERCEPTION_MARKERS, graph.PERCEPTION_ROBOT_FOUND,
                      graph.SCANNER_ANNOTATED, graph.HEALTH[NODE_NAME]))
        self.pose_at = self.create_client(POSE_AT, graph.POSE_AT.name)
        self.create_subscription(INFO.type, INFO.name, self._on_info, INFO.subscriber_qos)
        self._image_sub: Any = None  # on the image topic while enabled
        self._follow_images()
        odometry = graph.FCU_ODOMETRY
        self.create_subscription(odometry.type, odometry.name, self._on_odometry,
                                 odometry.subscriber_qos)
        self.create_service(SET_BOOL, graph.SCANNER_ENABLE.name, self._on_enable)
        self.add_on_set_parameters_callback(self._on_set)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)

    @property
    def enabled(self) -> bool:
        return self.policy.enabled

    # -- control ---------------------------------------------------------------------------
    def _set_enabled(self, on: bool) -> None:
        if self.policy.enable(self.now().nanoseconds, on):
            if on:
                self.tracker.reset()  # the regions it knew are minutes old
            self._follow_images()

    def _follow_images(self) -> None:
        """On the image topic while enabled, off it while not (no frame to render)."""
        if self.enabled and self._image_sub is None:
            self._image_sub = self.create_subscription(IMAGE.type, IMAGE.name, self._on_image,
                                                       IMAGE.subscriber_qos)
        elif not self.enabled and self._image_sub is not None:
            self.destroy_subscription(self._image_sub)
            self._image_sub = self._waiting = None

    def _on_enable(self, request: Any, response: Any) -> Any:
        self._set_enabled(bool(request.data))
        response.success = True
        response.message = f"scanning {'enabled' if self.enabled else 'disabled'}"
        return response

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        for p in params:
            if p.name == "mode":
                if (problem := self.policy.set_mode(p.value)) is not None:
                    return SetParametersResult(False, problem)
            elif p.name == "enabled":
                self._set_enabled(bool(p.value))
        return SetParametersResult(True)

    # -- images ----------------------------------------------------------------------------
    def _on_info(self, msg: Any) -> None:
        self.camera = np.asarray(msg.k, dtype=np.float64).reshape(3, 3)

    def _on_odometry(self, msg: Any) -> None:
        self.policy.height(self.now().nanoseconds, float(msg.pose.pose.position.z))

    def _on_image(self, msg: Any) -> None:
        now_ns = self.now().nanoseconds
        camera = self.camera
        if not self.policy.image(now_ns, camera is not None) or camera is None:
            return  # (camera None: never scanned; the second test is for the type checker)
        if msg.encoding != "rgb8":
            self.get_logger().warn(f"{IMAGE.name}: expected rgb8, got {msg.encoding!r}")
            return
        if self._scanning:  # still on the last frame: this one waits (the newest only)
            self.frames_dropped += self._waiting is not None
            self._waiting = msg
            return
        self._start_scan(msg, camera)

    def _start_scan(self, msg: Any, camera: np.ndarray) -> None:
        image = np.asarray(msg.data, dtype=np.uint8).reshape(msg.height, msg.width, 3)
        mode = self.policy.mode
        self.tracker.min_side_px = self.params.min_side_px(
            mode, float(camera[1, 1]), self.policy.marker_range_m(self.now().nanoseconds))
        sides = self.params.side_lengths
        tracker = self.tracker

        def scan() -> list[Marker]:
            return measure_all(tracker.find(image, mode), camera, sides)

        self._scanning = True
        self.create_task(self._scan(msg, image, scan))

    async def _scan(self, msg: Any, image: np.ndarray, scan: Callable[[], list[Marker]]) -> None:
        """The frame's markers, worked out off the callbacks' thread in ``processing_s``
        (:meth:`runtime.node.Node.offload`), then published."""
        try:
            markers = await self.offload(scan, self.params.processing_s)
        finally:
            self._scanning = False
            waiting, self._waiting = self._waiting, None
            if waiting is not None and self.camera is not None and self.enabled:
                self._start_scan(waiting, self.camera)
        now_ns = self.now().nanoseconds
        stamp_ns = Time.from_msg(msg.header.stamp).nanoseconds
        due = self.policy.scanned(now_ns, [(m.id, m.kind) for m in markers])
        header = msg.header
        self.markers_pub.publish(interfaces.new(
            "quadmission_interfaces/msg/MarkerDetectionArray", header=header,
            detections=[detection_msg(m, header) for m in markers]))
        annotated: np.ndarray | None = None
        if self.policy.annotated_due(now_ns, self.annotated_pub.get_subscription_count()):
            annotated = annotate(image, markers)
            self.annotated_pub.publish(interfaces.new(
                "sensor_msgs/msg/Image", header=header, height=msg.height, width=msg.width,
                encoding="rgb8", step=3 * msg.width, data=annotated.reshape(-1)))
        for i in due:
            if annotated is None:
                annotated = annotate(image, markers)
            self.create_task(self._report_robot(markers[i], stamp_ns, image, annotated))

    async def _report_robot(self, marker: Marker, stamp_ns: int, image: np.ndarray,
                            annotated: np.ndarray) -> None:
        request = interfaces.new(POSE_AT.Request, stamp=Time(stamp_ns).to_msg())
        response = await self.pose_at.call_async(request)
        for _ in range(POSE_AT_RETRIES):  # the frame can be ahead of the odometry
            if response.success:
                break
            await self.sleep(POSE_AT_RETRY_S)
            response = await self.pose_at.call_async(request)
        if not response.success:
            self.get_logger().warn(f"robot {marker.id}: no pose at capture time: "
                                   f"{response.message}")
            return
        pose = response.odometry.pose.pose
        o, p = pose.orientation, pose.position
        q = (float(o.w), float(o.x), float(o.y), float(o.z))
        track = self.policy.sighting(marker.id, marker_in_map(
            np.array([p.x, p.y, p.z]), q, marker.position_cam, self.params.camera_position))
        assert track.mean is not None  # one sighting at least
        header = interfaces.new("std_msgs/msg/Header", stamp=Time(stamp_ns).to_msg(),
                                frame_id=MAP_FRAME)
        yaw = quat_to_yaw_f(q)
        quality = self.params.jpeg_quality
        self.robot_pub.publish(interfaces.new(
            "quadmission_interfaces/msg/RobotFound", header=header, marker_id=marker.id,
            pose=interfaces.new(
                "geometry_msgs/msg/Pose",
                position=interfaces.new("geometry_msgs/msg/Point", x=float(track.mean[0]),
                                        y=float(track.mean[1]), z=float(track.mean[2])),
                orientation=interfaces.new("geometry_msgs/msg/Quaternion",
                                           w=math.cos(yaw / 2.0), z=math.sin(yaw / 2.0))),
            position_std=track.horizontal_std, sightings=track.sightings,
            picture_raw=jpeg_msg(image, header, quality),
            picture_annotated=jpeg_msg(annotated, header, quality)))

    # -- health ----------------------------------------------------------------------------
    def _publish_health(self) -> None:
        now = self.now()
        problems = [_PROBLEM_TEXT[p] for p in
                    self.policy.problems(now.nanoseconds, self.camera is not None)]
        level = HEALTH.LEVEL_ERROR if problems else HEALTH.LEVEL_OK
        message = "; ".join(problems) if problems else ("" if self.enabled else "disabled")
        policy = self.policy
        values = {"enabled": str(self.enabled).lower(), "mode": policy.mode.value,
                  "frames": policy.frames, "frames_with_markers": policy.frames_with_markers,
                  "detections": policy.detections, "robots_seen": len(policy.robots),
                  "frames_dropped": self.frames_dropped}
        self.health_pub.publish(health_report(NODE_NAME, level, message, values, now.to_msg()))


__all__ = ["NODE_NAME", "ArucoScannerNode", "ScannerParams"]
