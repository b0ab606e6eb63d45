"""The mapping node: depth clouds + the pose at their capture time -> ``/map/points``.

Each ``/camera/depth/points`` cloud (at most ``process_rate_hz``) is placed in the map frame
with the body pose the bridge reports for the cloud's capture stamp (``/fcu/pose_at``; never
simulator truth) and added to a :class:`~navigation.mapping.VoxelMap`. The map (optionally
started from ``map_file``) is published on ``/map/points`` at ``publish_rate_hz`` when a cloud
was fused since the last one, stamped with the newest fused cloud's capture time: a map
stamped t holds everything the camera saw until t, even when that added no voxel (the
navigator waits for such a map after a turn before it flies on), and even when it holds
no voxel at all (nothing in range: free space, which the path finder plans on; see
:func:`~navigation.mapping.map_to_publish`). :meth:`MappingNode.save` writes it as PCD/PLY.
Parameters: ``config/mapping.yaml``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

import interfaces
from flight_control.health import MODULE_HEALTH, health_report
from interfaces import graph
from navigation.cloud_msgs import cloud_msg, cloud_points
from navigation.mapping import VoxelMap, camera_to_map, load_map, map_to_publish, save_map
from navigation.params import MappingParams
from runtime import Node, Time

NODE_NAME = "mapping"
POSE_AT = graph.POSE_AT.interface()
MAP_FRAME = "map"
POSE_ATTEMPTS = 5  # /fcu/pose_at requests per cloud
POSE_RETRY_S = 0.05  # s between them (the odometry of the capture time is in flight)


class MappingNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(MappingParams)
        self.map = VoxelMap(self.params.voxel_size)
        if self.params.map_file:
            self.map.add(load_map(self.params.map_file))
        self.clouds_fused = 0
        self.clouds_dropped = 0  # no pose for the stamp
        self.last_drop = ""
        #: (capture stamp [ns], position [m], orientation wxyz) of each fused cloud
        self.fused_poses: list[tuple[int, tuple[float, ...], tuple[float, ...]]] = []
        self._last_ns: int | None = None
        self._published_fused: int | None = None  # clouds_fused at the last publish
        self.map_stamp = Time(0).to_msg()  # capture time of the newest fused cloud
        self._pending = False
        self.pose_at = self.create_client(POSE_AT, graph.POSE_AT.name)
        self._valid_since_ns: int | None = None  # the FCU's position valid since then
        for topic, callback in ((graph.FCU_STATUS, self._on_status),
                                (graph.CAMERA_DEPTH_POINTS, self._on_cloud)):
            self.create_subscription(topic.type, topic.name, callback, topic.subscriber_qos)
        self.map_pub, self.health_pub = (self.create_publisher(t.type, t.name, t.qos) for t in
                                         (graph.MAP_POINTS, graph.HEALTH[NODE_NAME]))
        self.create_timer(1.0 / self.params.publish_rate_hz, self._publish)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)

    def _on_status(self, msg: Any) -> None:
        if not msg.position_valid:
            self._valid_since_ns = None
        elif self._valid_since_ns is None:
            self._valid_since_ns = Time.from_msg(msg.header.stamp).nanoseconds

    def estimate_settled(self, stamp_ns: int) -> bool:
        """Whether the FCU's position estimate had been valid for ``settle_s`` at
        ``stamp_ns`` (before that, its pose can be metres and radians off)."""
        return (self._valid_since_ns is not None
                and stamp_ns - self._valid_since_ns >= int(self.params.settle_s * 1e9))

    def _on_cloud(self, msg: Any) -> None:
        stamp = Time.from_msg(msg.header.stamp)
        if not self.estimate_settled(stamp.nanoseconds):
            return
        period_ns = int(1e9 / self.params.process_rate_hz)
        if self._pending or (self._last_ns is not None
                             and stamp.nanoseconds - self._last_ns < period_ns):
            return
        self._last_ns = stamp.nanoseconds
        self._pending = True
        self.create_task(self._fuse(cloud_points(msg), msg.header.stamp))

    async def _fuse(self, points: np.ndarray, stamp: Any) -> None:
        """Ask the bridge for the pose at the capture time; the odometry of that instant
        may still be on its way over the link, so ask again a few times."""
        request = interfaces.new(POSE_AT.Request, stamp=stamp)
        for _ in range(POSE_ATTEMPTS):
            response = await self.pose_at.call_async(request)
            if response.success:
                break
            await self.sleep(POSE_RETRY_S)
        self._pending = False
        if not response.success:
            self.clouds_dropped += 1
            self.last_drop = str(response.message)
            return
        pose = response.odometry.pose.pose
        p, o = pose.position, pose.orientation
        self.fused_poses.append((Time.from_msg(stamp).nanoseconds, (p.x, p.y, p.z),
                                 (o.w, o.x, o.y, o.z)))
        world = camera_to_map(points, (p.x, p.y, p.z), (o.w, o.x, o.y, o.z),
                              self.params.depth_camera_position,
                              min_range=self.params.min_range, max_range=self.params.max_range)
        self.map.add(world[world[:, 2] >= self.params.min_z])
        self.clouds_fused += 1
        if Time.from_msg(stamp).nanoseconds > Time.from_msg(self.map_stamp).nanoseconds:
            self.map_stamp = stamp

    def _publish(self) -> None:
        if not map_to_publish(self.clouds_fused, self._published_fused, len(self.map)):
            return
        self._published_fused = self.clouds_fused
        self.map_pub.publish(cloud_msg(self.map.points(), self.map_stamp, MAP_FRAME))

    def save(self, path: Path | str) -> Path:
        """Write the map as PCD/PLY (by the suffix)."""
        return save_map(path, self.map.points())

    def _publish_health(self) -> None:
        level = MODULE_HEALTH.LEVEL_OK if self.clouds_fused or len(self.map) else \
            MODULE_HEALTH.LEVEL_WARN
        message = "" if level == MODULE_HEALTH.LEVEL_OK else "no depth cloud fused yet"
        self.health_pub.publish(health_report(
            "mapping", level, message,
            {"voxels": len(self.map), "clouds_fused": self.clouds_fused,
             "clouds_dropped": self.clouds_dropped,
             "last_drop": self.last_drop}, self.now().to_msg()))


__all__ = ["MappingNode"]
