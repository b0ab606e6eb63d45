"""The ground station's node: topics in, :class:`~ground_station.view.OperatorView` out,
operator commands onto ``/mission/command``.

It converts messages into the view's plain values (pose and heading from the bridge's
odometry, FCU flags, time-sync and module health, the mission state and events, the
planned path from ``/navigation/path`` or the navigator's feedback, the voxel map, a
throttled JPEG of the down camera, the robot pictures). Commands arrive from the web
server's thread through a queue and are published from a timer, in the executor's
thread, so the node keeps to the runtime's one-thread rule.
"""

from __future__ import annotations

import math
import queue
from typing import Any

import cv2
import numpy as np

import interfaces
from flight_control.frames import quat_to_yaw_f
from ground_station.commands import OperatorCommand
from ground_station.layout import FieldLayout
from ground_station.params import GroundStationParams
from ground_station.view import OperatorView, Pose2, RobotPicture
from interfaces import graph
from runtime import Node

NODE_NAME = "ground_station"
_POINT_FIELD_FLOAT32 = 7  # sensor_msgs/PointField.FLOAT32


def yaw_of(q: Any) -> float:
    """Heading [rad, ENU] of a geometry_msgs/Quaternion (its fields in
    :func:`flight_control.frames.quat_to_yaw_f`'s order)."""
    return quat_to_yaw_f((q.w, q.x, q.y, q.z))


def image_rgb(msg: Any) -> np.ndarray | None:
    """A sensor_msgs/Image as an RGB array (rgb8, bgr8 or mono8); None for another
    encoding, an empty image, or sizes that do not add up (a step shorter than a row,
    fewer bytes than height * step): the page skips it instead of the node crashing."""
    channels = {"rgb8": 3, "bgr8": 3, "mono8": 1}.get(msg.encoding)
    if channels is None or msg.height == 0 or msg.width == 0:
        return None
    if msg.step < msg.width * channels or len(msg.data) < msg.height * msg.step:
        return None
    data = np.asarray(msg.data, dtype=np.uint8)[: msg.height * msg.step]
    rows = data.reshape(msg.height, msg.step)[:, : msg.width * channels]
    image = rows.reshape(msg.height, msg.width, channels)
    if msg.encoding == "bgr8":
        return np.ascontiguousarray(image[:, :, ::-1])
    if channels == 1:
        return np.repeat(image, 3, axis=2)
    return image


def jpeg(rgb: np.ndarray, width_px: int, quality: int) -> bytes:
    """``rgb`` scaled to ``width_px`` wide (never up) and encoded as JPEG."""
    h, w = rgb.shape[:2]
    if w > width_px:
        rgb = cv2.resize(rgb, (width_px, max(1, round(h * width_px / w))),
                         interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR),
                           [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return buf.tobytes()


def cloud_xyz(msg: Any, max_points: int) -> list[tuple[float, float, float]]:
    """x, y, z of a PointCloud2 with float32 x/y/z fields, thinned to ``max_points``;
    none when a field lies past ``point_step`` or the data is shorter than its points."""
    offsets = {f.name: f.offset for f in msg.fields if f.datatype == _POINT_FIELD_FLOAT32}
    if not {"x", "y", "z"} <= offsets.keys() or msg.point_step == 0 or max_points == 0:
        return []
    n = msg.width * msg.height
    if (max(offsets[a] for a in "xyz") + 4 > msg.point_step
            or len(msg.data) < n * msg.point_step):
        return []
    raw = np.asarray(msg.data, dtype=np.uint8)[: n * msg.point_step].reshape(n, msg.point_step)
    stride = max(1, math.ceil(n / max_points))
    raw = raw[::stride]
    cols = [raw[:, offsets[a]: offsets[a] + 4].copy().view(np.float32)[:, 0] for a in "xyz"]
    xyz = np.stack(cols, axis=1)
    xyz = xyz[np.all(np.isfinite(xyz), axis=1)]
    return [(float(x), float(y), float(z)) for x, y, z in xyz]


def _constants(typename: str, prefix: str) -> dict[int, str]:
    constants, _ = interfaces.describe(typename)
    return {int(c.value): c.name[len(prefix):].lower() for c in constants
            if c.name.startswith(prefix)}


PHASES = _constants("quadmission_interfaces/msg/MissionState", "PHASE_")
EVENT_KINDS = _constants("quadmission_interfaces/msg/MissionEvent", "KIND_")
SEVERITIES = _constants("quadmission_interfaces/msg/MissionEvent", "SEVERITY_")
HEALTH_LEVELS = _constants("quadmission_interfaces/msg/ModuleHealth", "LEVEL_")


def _stamp_s(header: Any) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


class GroundStationNode(Node):
    """Feeds ``self.view``; ``submit()`` queues an operator command (any thread)."""

    def __init__(self, layout: FieldLayout | None = None, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = p = self.declare_params(GroundStationParams)
        self.view = OperatorView(layout=layout, phase_names=dict(PHASES),
                                 path_spacing_m=p.flown_path_spacing_m,
                                 path_max_points=p.flown_path_max_points)
        self._queue: queue.Queue[OperatorCommand] = queue.Queue()
        self._next_camera_ns = 0
        self.sent: list[OperatorCommand] = []
        command = graph.MISSION_COMMAND
        self.command_pub = self.create_publisher(command.type, command.name, command.qos)
        navigate = graph.NAVIGATE
        subs = (
            (graph.FCU_ODOMETRY, self._on_odometry),
            (graph.FCU_STATUS, self._on_status),
            (graph.FCU_TIMESYNC_STATUS, self._on_timesync),
            (graph.HEALTH["flight_control"], self._on_health),
            (graph.MISSION_STATE, self._on_state),
            (graph.MISSION_EVENTS, self._on_event),
            (graph.SEQUENCE_PROPOSAL, self._on_proposal),
            (graph.NAVIGATION_PATH, self._on_path),
            ((navigate.feedback_type, navigate.feedback_topic), self._on_navigate_feedback),
            (graph.MAP_POINTS, self._on_map),
            (graph.CAMERA_DOWN_RAW, self._on_camera),
            (graph.PERCEPTION_ROBOT_FOUND, self._on_robot),
        )
        for topic, callback in subs:  # a monitor: its QoS matches every writer
            msgtype, name = topic if isinstance(topic, tuple) else (topic.type, topic.name)
            self.create_subscription(msgtype, name, callback, graph.MONITOR_QOS)
        self.create_timer(p.command_period_s, self._send_queued)

    def _t(self) -> float:
        return self.now().nanoseconds / 1e9

    # telemetry ---------------------------------------------------------------------------
    def _on_odometry(self, msg: Any) -> None:
        pose = msg.pose.pose
        valid = self.view.fcu.get("position_valid", False)  # the FCU must vouch for it
        self.view.on_pose(self._t(), Pose2(pose.position.x, pose.position.y, pose.position.z,
                                           yaw_of(pose.orientation)), flown=valid)

    def _on_status(self, msg: Any) -> None:
        remaining = float(msg.battery_remaining)
        self.view.on_fcu(self._t(), {
            "connected": bool(msg.connected), "armed": bool(msg.armed),
            "offboard": bool(msg.offboard), "landed": bool(msg.landed),
            "failsafe": bool(msg.failsafe), "offboard_signal_lost": bool(msg.offboard_signal_lost),
            "position_valid": bool(msg.position_valid), "nav_state": int(msg.nav_state),
            "battery_warning": int(msg.battery_warning),
            "battery_remaining": None if math.isnan(remaining) else round(remaining, 3),
            "stamp_s": round(_stamp_s(msg.header), 3)})

    def _on_timesync(self, msg: Any) -> None:
        self.view.on_timesync(self._t(), {
            "converged": bool(msg.converged), "offset_us": int(msg.offset_estimated_us),
            "rtt_us": int(msg.rtt_us), "samples": int(msg.samples), "resets": int(msg.resets)})

    def _on_health(self, msg: Any) -> None:
        self.view.on_health(self._t(), {
            "level": HEALTH_LEVELS.get(msg.level, str(msg.level)),
            "modules": [{"name": m.name, "level": HEALTH_LEVELS.get(m.level, str(m.level)),
                         "message": m.message} for m in msg.modules]})

    def _on_state(self, msg: Any) -> None:
        self.view.on_mission_state(self._t(), {
            "phase": int(msg.phase), "phase_name": PHASES.get(msg.phase, str(msg.phase)),
            "previous_phase": int(msg.previous_phase), "state": msg.state,
            "sub_state": msg.sub_state, "score": int(msg.score),
            "pads_skipped": [int(p) for p in msg.pads_skipped],
            "stop_reason": msg.stop_reason,
            "elapsed_s": round(msg.elapsed.sec + msg.elapsed.nanosec * 1e-9, 1),
            "robot_marker_id": int(msg.robot_marker_id),
            "landing_sequence": [int(p) for p in msg.landing_sequence],
            "pads_landed": [int(p) for p in msg.pads_landed],
            "target_pad_id": int(msg.target_pad_id)})

    def _on_event(self, msg: Any) -> None:
        self.view.on_event(self._t(), {
            "t_s": round(_stamp_s(msg.header), 2),
            "severity": SEVERITIES.get(msg.severity, str(msg.severity)),
            "kind": EVENT_KINDS.get(msg.kind, str(msg.kind)),
            "marker_id": int(msg.marker_id), "message": msg.message})

    def _on_proposal(self, msg: Any) -> None:
        self.view.on_proposal(self._t(), [int(p) for p in msg.pad_ids])

    def _on_path(self, msg: Any) -> None:
        self.view.on_planned_path(self._t(), [(p.pose.position.x, p.pose.position.y)
                                              for p in msg.poses], graph.NAVIGATION_PATH.name)

    def _on_navigate_feedback(self, msg: Any) -> None:
        poses = msg.feedback.path.poses
        self.view.on_planned_path(self._t(), [(p.pose.position.x, p.pose.position.y)
                                              for p in poses], "navigate feedback")

    def _on_map(self, msg: Any) -> None:
        self.view.on_map(self._t(), cloud_xyz(msg, self.params.map_max_points))

    def _on_camera(self, msg: Any) -> None:
        now = self.now().nanoseconds
        if now < self._next_camera_ns:
            return
        rgb = image_rgb(msg)
        if rgb is None:
            return
        self._next_camera_ns = now + round(self.params.camera_period_s * 1e9)
        self.view.on_camera(self._t(), jpeg(rgb, self.params.camera_width_px,
                                            self.params.jpeg_quality))

    def _on_robot(self, msg: Any) -> None:
        # the scanner's JPEGs as they are: the annotated one, else the raw capture
        picture = next((bytes(p.data) for p in (msg.picture_annotated, msg.picture_raw)
                        if len(p.data) and p.format.lower() in ("jpeg", "jpg")), None)
        self.view.on_robot(self._t(), RobotPicture(int(msg.marker_id), msg.pose.position.x,
                                                   msg.pose.position.y, int(msg.sightings),
                                                   picture))

    # commands ----------------------------------------------------------------------------
    def submit(self, command: OperatorCommand) -> None:
        """Queue an operator command; it is published at the next command tick."""
        self._queue.put(command)

    def _send_queued(self) -> None:
        while True:
            try:
                command = self._queue.get_nowait()
            except queue.Empty:
                return
            t = self.now()
            sequence = interfaces.new("quadmission_interfaces/msg/LandingSequence",
                                      pad_ids=list(command.sequence))
            msg = interfaces.new("quadmission_interfaces/msg/MissionCommand",
                                 command=getattr(interfaces.get_message(
                                     "quadmission_interfaces/msg/MissionCommand"),
                                     command.verb.constant),
                                 sequence=sequence, reason=command.reason)
            for header in (msg.header, sequence.header):
                header.stamp.sec, header.stamp.nanosec = divmod(t.nanoseconds, 10**9)
            self.command_pub.publish(msg)
            self.sent.append(command)


__all__ = ["NODE_NAME", "PHASES", "GroundStationNode",
           "cloud_xyz", "image_rgb", "jpeg", "yaw_of"]
