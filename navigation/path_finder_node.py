"""The path finder (seed 003, sec. 3.3.2): ``/navigation/plan_path`` on the voxel graph.

It converts messages and maps errors; the graph is :mod:`navigation.voxel_graph`, the search
:mod:`navigation.astar`. The graph is built from ``map_file`` (when given) plus the live
``/map/points`` (when ``use_live_map``), over the field the app gives
(``field_min``/``field_max``), lazily: the first request builds it (from the disk cache
when ``cache_dir`` is set); a request after the map changed updates it where the change
matters (:func:`~navigation.voxel_graph.update_graph`: only the block the new points reach,
nothing when they fall in cubes already full, e.g. more of a wall already mapped), to the
same graph a full build gives. A map on ``/map/points`` is what the depth camera saw: one
with no point in the field (the start pad facing open floor) is free space, a graph
bounded only by the field's walls, floor and ceiling, so the path finder is ready with it;
"no map yet" is only for before any map (no ``map_file``, nothing on ``/map/points``).
A path's header stamp is the map's (the capture time of the newest depth cloud in it), so
the navigator knows what the plan had seen. Every :class:`~navigation.errors.PlanningError`
becomes a ``PlanPath`` result code here, in :data:`RESULT_OF`, with the error's text.
Parameters: ``config/path_finder.yaml``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

import interfaces
from flight_control.health import MODULE_HEALTH, health_report
from flight_control.params import FIELD_SOURCE, FieldParams
from interfaces import graph
from navigation.astar import Heuristic, Workspace, plan
from navigation.cloud_msgs import cloud_points
from navigation.errors import (
    GoalOccupied,
    GraphError,
    NoPathFound,
    OutOfBounds,
    PlanningError,
    PlanningTimedOut,
    StartOccupied,
)
from navigation.mapping import load_map
from navigation.params import PathFinderParams
from navigation.voxel_graph import (
    VoxelGraph,
    build_graph,
    cached_graph,
    count_points,
    update_graph,
)
from runtime import Node, ParameterError, Time

NODE_NAME = "path_finder"
PLAN_PATH = graph.PLAN_PATH.interface()
MAP_FRAME = "map"
_R: Any = PLAN_PATH.Response
#: The one place where planning errors become result codes.
RESULT_OF: dict[type[PlanningError], int] = {
    StartOccupied: _R.RESULT_START_OCCUPIED,
    GoalOccupied: _R.RESULT_GOAL_OCCUPIED,
    OutOfBounds: _R.RESULT_OUT_OF_BOUNDS,
    NoPathFound: _R.RESULT_NO_PATH,
    PlanningTimedOut: _R.RESULT_NO_PATH,
}


def path_msg(points: np.ndarray, stamp: Any) -> Any:
    """A nav_msgs/Path in the map frame through ``points`` (N, 3) [m]."""
    header = interfaces.new("std_msgs/msg/Header", stamp=stamp, frame_id=MAP_FRAME)
    poses = []
    for p in points:
        pose = interfaces.new("geometry_msgs/msg/PoseStamped", header=header)
        pose.pose.position = interfaces.new("geometry_msgs/msg/Point", x=float(p[0]),
                                            y=float(p[1]), z=float(p[2]))
        pose.pose.orientation.w = 1.0
        poses.append(pose)
    return interfaces.new("nav_msgs/msg/Path", header=header, poses=poses)


def path_points(msg: Any) -> np.ndarray:
    """The (N, 3) positions [m] of a nav_msgs/Path."""
    return np.array([[p.pose.position.x, p.pose.position.y, p.pose.position.z]
                     for p in msg.poses], dtype=np.float64).reshape(-1, 3)


class PathFinderNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(PathFinderParams)
        try:
            field = self.declare_params(FieldParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        if self.params.unknown_is_occupied:
            raise ParameterError(
                "true needs the cubes the depth camera observed, which /map/points does not "
                "carry; use build_graph(observed=...) directly",
                key="path_finder.unknown_is_occupied")
        self.field_min = np.asarray(field.field_min, dtype=np.float64)
        self.field_max = np.asarray(field.field_max, dtype=np.float64)
        self.static_points = (load_map(self.params.map_file) if self.params.map_file
                              else np.empty((0, 3)))
        self.live_points = np.empty((0, 3))
        #: what a mapping node that died had seen: the map only grows, so a smaller one is
        #: a restarted mapping node's, which starts empty; its points are kept beside it
        self.kept_points = np.empty((0, 3))
        self._graphs: dict[float, VoxelGraph] = {}  # by request clearance
        self._graph_version: dict[float, int] = {}  # the map version each graph is of
        self._counts: tuple[int, np.ndarray] | None = None  # (map version, points per cube)
        self.map_stamp = Time(0).to_msg()  # of the map the graphs are of
        self._workspace: Workspace | None = None  # search arrays, reused while the grid holds
        self.heuristic = Heuristic[self.params.heuristic.upper()]
        self.map_version = 0
        self.graph_builds = 0  # full builds
        self.graph_updates = 0  # updates of a block of the graph
        self.graph_unchanged = 0  # map changes that did not matter to the graph
        self.cubes_updated = 0  # cubes recomputed by the updates
        self.requests = 0
        self.last_error = ""
        if self.params.use_live_map:
            live = graph.MAP_POINTS
            self.create_subscription(live.type, live.name, self._on_map, live.subscriber_qos)
        self.create_service(PLAN_PATH, graph.PLAN_PATH.name, self._plan_path)
        health = graph.HEALTH[NODE_NAME]
        self.health_pub = self.create_publisher(health.type, health.name, health.qos)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)

    def _on_map(self, msg: Any) -> None:
        points = cloud_points(msg)
        if len(points) < len(self.live_points):
            self.get_logger().info(f"/map/points shrank from {len(self.live_points)} to "
                                   f"{len(points)} points (mapping restarted): keeping the "
                                   "old map's")
            self.kept_points = np.vstack([self.kept_points, self.live_points])
        self.live_points = points
        self.map_stamp = msg.header.stamp
        self.map_version += 1

    def map_points(self) -> np.ndarray:
        return np.vstack([self.static_points, self.kept_points, self.live_points])

    @property
    def has_map(self) -> bool:
        """A map file or a live map arrived (an empty live map too: the camera saw nothing
        to avoid, which is free space)."""
        return len(self.static_points) > 0 or self.map_version > 0

    def graph(self, clearance: float = 0.0) -> VoxelGraph | None:
        """The graph of the current map (None: no map yet). Raises GraphError."""
        if self._graph_version.get(clearance) == self.map_version:
            return self._graphs[clearance]
        if not self.has_map:
            return None
        points = self.map_points()
        seen = self.map_version > 0  # a live map: no point in the field is free space
        old = self._graphs.get(clearance)
        if old is not None:
            if self._counts is None or self._counts[0] != self.map_version:
                self._counts = (self.map_version,
                                count_points(points, old.grid, empty_is_free=seen))
            graph, cubes = update_graph(old, self._counts[1])
            self.graph_updates += cubes > 0
            self.graph_unchanged += cubes == 0
            self.cubes_updated += cubes
            self._graphs[clearance] = graph
            self._graph_version[clearance] = self.map_version
            return graph
        gp = self.params.graph(clearance)
        if self.params.cache_dir:
            graph, _ = cached_graph(points, self.field_min, self.field_max, gp,
                                    Path(self.params.cache_dir), empty_is_free=seen)
        else:
            graph = build_graph(points, self.field_min, self.field_max, gp, empty_is_free=seen)
        self.graph_builds += 1
        self._graphs[clearance] = graph
        self._graph_version[clearance] = self.map_version
        return graph

    def _plan_path(self, request: Any, response: Any) -> Any:
        self.requests += 1
        start = np.array([request.start.x, request.start.y, request.start.z])
        goal = np.array([request.goal.x, request.goal.y, request.goal.z])
        clearance = float(request.clearance)
        if not (np.all(np.isfinite(start)) and np.all(np.isfinite(goal))
                and math.isfinite(clearance) and clearance >= 0.0):
            response.result = _R.RESULT_OUT_OF_BOUNDS
            response.message = "start, goal and clearance must be finite (clearance >= 0)"
            return self._failed(response)
        try:
            graph = self.graph(clearance)
        except GraphError as exc:
            response.result = _R.RESULT_NO_MAP
            response.message = f"no usable map: {exc}"
            return self._failed(response)
        if graph is None:
            response.result = _R.RESULT_NO_MAP
            response.message = "no map yet (no map_file and nothing on /map/points)"
            return self._failed(response)
        try:
            if self._workspace is None or self._workspace.size != graph.grid.size:
                self._workspace = Workspace(graph.grid.size)
            planned = plan(graph, start, goal, snap_radius=self.params.snap_radius,
                           max_expansions=self.params.max_expansions, heuristic=self.heuristic,
                           workspace=self._workspace)
        except PlanningError as exc:
            response.result = RESULT_OF[type(exc)]
            response.message = f"{type(exc).__name__}: {exc}"
            return self._failed(response)
        response.result = _R.RESULT_OK
        response.success = True
        response.message = (f"{len(planned.points)} waypoints, {planned.length:.2f} m "
                            f"({planned.expansions} cubes expanded)")
        response.path = path_msg(planned.points, self.map_stamp)
        response.length = planned.length
        self.last_error = ""
        return response

    def _failed(self, response: Any) -> Any:
        response.success = False
        response.path = path_msg(np.empty((0, 3)), self.map_stamp)
        self.last_error = str(response.message)
        return response

    def _publish_health(self) -> None:
        level = MODULE_HEALTH.LEVEL_OK if self.has_map else MODULE_HEALTH.LEVEL_WARN
        self.health_pub.publish(health_report(
            "path_finder", level, "" if self.has_map else "no map yet",
            {"map_points": len(self.static_points) + len(self.live_points),
             "map_version": self.map_version, "graph_builds": self.graph_builds,
             "graph_updates": self.graph_updates, "graph_unchanged": self.graph_unchanged,
             "requests": self.requests, "last_error": self.last_error},
            self.now().to_msg()))


__all__ = ["PLAN_PATH", "RESULT_OF", "PathFinderNode", "path_msg", "path_points"]
