"""The mapping node through its topics: depth clouds and /fcu/pose_at in, /map/points out.
A map stamped t holds every cloud captured until t, even one that added no voxel (the
navigator waits for such a map after a turn), and a cloud with nothing in range (the start
pad facing open floor) is a map too: free space, which the path finder plans on."""

from __future__ import annotations

from typing import Any

import numpy as np

import interfaces
from interfaces import graph
from navigation.cloud_msgs import cloud_msg, cloud_points
from navigation.mapping_node import POSE_AT, MappingNode
from navigation.path_finder_node import PathFinderNode, path_points
from runtime import DeterministicExecutor, Node, Time, qos_profile_default

WALL = np.array([(2.0, y, z) for y in np.arange(-1.0, 1.0, 0.1)
                 for z in np.arange(-0.5, 0.5, 0.1)])  # 2 m ahead of the camera (FLU)
# open floor ahead, seen from 1.5 m: every point below min_z once in the map frame
FLOOR = np.array([(x, y, -1.5) for x in np.arange(1.5, 5.0, 0.5)
                  for y in np.arange(-1.0, 1.0, 0.5)])


class Fcu(Node):
    """The bridge's side: the vehicle hovers at (1, 2, 1.5) facing east, its position valid."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("fcu_side", **kwargs)
        self.status = self.create_publisher("quadmission_interfaces/msg/FcuStatus",
                                            "/fcu/status", qos_profile_default)
        self.depth = self.create_publisher("sensor_msgs/msg/PointCloud2",
                                           graph.CAMERA_DEPTH_POINTS.name, qos_profile_default)
        self.maps: list[Any] = []
        self.create_subscription("sensor_msgs/msg/PointCloud2", graph.MAP_POINTS.name,
                                 self.maps.append, qos_profile_default)
        self.create_service(POSE_AT, "/fcu/pose_at", self._pose_at)
        self.create_timer(0.1, self._status)

    def _status(self) -> None:
        self.status.publish(interfaces.new(
            "quadmission_interfaces/msg/FcuStatus", connected=True, position_valid=True,
            header=interfaces.new("std_msgs/msg/Header", stamp=self.now().to_msg())))

    def _pose_at(self, request: Any, response: Any) -> Any:
        response.success = True
        pose = response.odometry.pose.pose
        pose.position.x, pose.position.y, pose.position.z = 1.0, 2.0, 1.5
        pose.orientation.w = 1.0
        return response


def test_a_cloud_with_nothing_new_still_advances_the_map_stamp() -> None:
    ex = DeterministicExecutor()
    mapping = MappingNode(context=ex.context, parameter_overrides={"settle_s": 0.5})
    fcu = Fcu(context=ex.context)
    for node in (mapping, fcu):
        ex.add_node(node)
    ex.spin_for(1.0)  # the estimate settles
    stamps = []
    for _ in range(2):  # the same wall twice: the second cloud adds no voxel
        stamps.append(ex.now().to_msg())
        fcu.depth.publish(cloud_msg(WALL, stamps[-1], "camera"))
        ex.spin_for(1.5)
    assert mapping.clouds_fused == 2
    assert len(fcu.maps) == 2  # published again, though the points are the same
    assert [Time.from_msg(m.header.stamp) for m in fcu.maps] == [Time.from_msg(s)
                                                                 for s in stamps]
    first, second = (cloud_points(m) for m in fcu.maps)
    assert np.array_equal(first, second)
    assert np.allclose(first[:, 0].mean(), 1.0 + 0.12 + 2.0, atol=0.06)  # in the map frame


def test_a_view_with_nothing_in_range_is_an_empty_map_the_path_finder_plans_on() -> None:
    ex = DeterministicExecutor()
    mapping = MappingNode(context=ex.context, parameter_overrides={"settle_s": 0.5})
    finder = PathFinderNode(context=ex.context, parameter_overrides={
        "field_min": [-2.0, -2.0, 0.0], "field_max": [8.0, 6.0, 3.0]})
    fcu = Fcu(context=ex.context)
    for node in (mapping, finder, fcu):
        ex.add_node(node)
    plan_path = interfaces.get_service(graph.PLAN_PATH.type)
    planner = fcu.create_client(plan_path, graph.PLAN_PATH.name)
    ex.spin_for(1.5)  # the estimate settles; no cloud yet
    assert fcu.maps == [] and finder.map_version == 0  # no map yet: nothing seen
    stamps = []
    for cloud in (np.empty((0, 3)), FLOOR):  # nothing in range, then only the floor
        stamps.append(ex.now().to_msg())
        fcu.depth.publish(cloud_msg(cloud, stamps[-1], "camera"))
        ex.spin_for(1.5)
    assert mapping.clouds_fused == 2 and len(mapping.map) == 0
    assert [len(cloud_points(m)) for m in fcu.maps] == [0, 0]  # maps, with no obstacle
    assert [Time.from_msg(m.header.stamp) for m in fcu.maps] == [Time.from_msg(s)
                                                                 for s in stamps]
    request = interfaces.new(plan_path.Request, start=interfaces.new(
        "geometry_msgs/msg/Point", x=1.0, y=2.0, z=1.5), goal=interfaces.new(
        "geometry_msgs/msg/Point", x=6.0, y=2.0, z=1.5))
    future = planner.call_async(request)
    assert ex.spin_until_future_complete(future, 2.0)
    reply = future.result()
    assert reply.success, reply.message
    assert len(path_points(reply.path)) == 2  # straight over the open floor
    assert Time.from_msg(reply.path.header.stamp) == Time.from_msg(stamps[-1])
