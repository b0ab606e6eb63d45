"""The navigator (seed 003, sec. 3.3.2): takeoff, explore and navigate as actions.

It flies only through the flight-control actions (``/flight_control/takeoff``, ``reach``,
``turn``) and plans only through ``/navigation/plan_path``. The decisions are the pure
policies' of :mod:`navigation.navigator_policy` (read its docstring): ``/navigation/navigate``
follows a planned path and re-plans when a leg is blocked (:class:`NavigatePolicy`),
``/navigation/explore`` flies the arena's explore path or coverage lanes in sweeps until a
``stop_marker_ids`` marker is on ``/perception/markers`` (:class:`ExplorePolicy`; a goal
that follows an interrupted one for the same area, altitude and markers goes on from the first
waypoint that one did not reach, with its coverage: the node keeps
:class:`~navigation.navigator_policy.ExploreSoFar` between goals, in memory only), and
``/navigation/takeoff`` climbs with ``/flight_control/takeoff``, then makes
``survey_turns`` quarter turns (:class:`SurveyPolicy`). This node feeds a policy the pose,
the time, the markers and the answers of the planner and the flight actions, and carries
out its commands.

Parameters: ``config/navigator.yaml`` (+ ``arena``, ``start_pad`` and the field from the app).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import quat_to_yaw_f
from flight_control.health import MODULE_HEALTH, health_report
from flight_control.params import FIELD_SOURCE, FieldParams
from flight_control.policy import Finish, Log, Outcome, Sleep
from interfaces import graph
from navigation.coverage import load_explore_paths
from navigation.navigator_messages import (
    EXPLORE,
    EXPLORE_CODES,
    LEG_BLOCKED,
    NAVIGATE,
    NAVIGATE_CODES,
    REACH,
    TAKEOFF,
    TAKEOFF_CODES,
    TURN,
    flight_goal,
    plan_request,
)
from navigation.navigator_policy import (
    ActionState,
    CancelAction,
    ExploreFinish,
    ExplorePolicy,
    ExploreProgress,
    ExploreSoFar,
    ExploreTuning,
    FollowTuning,
    Inputs,
    NavigatePolicy,
    NavigateProgress,
    Plan,
    Planned,
    PollAction,
    SendReach,
    SendTurn,
    Sent,
    SurveyPolicy,
    explore_waypoints,
)
from navigation.params import NavigatorParams
from navigation.path_finder_node import PLAN_PATH, path_msg, path_points
from runtime import (
    ActionClient,
    ActionServer,
    Duration,
    Node,
    ParameterError,
    ServerGoalHandle,
    Time,
)
from runtime.parameters import config_path

NODE_NAME = "navigator"


class NavigatorNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(NavigatorParams)
        try:
            field = self.declare_params(FieldParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        self.field_min = np.asarray(field.field_min, dtype=np.float64)
        self.field_max = np.asarray(field.field_max, dtype=np.float64)
        self.follow = FollowTuning.of(self.params)
        self.explore_tuning = ExploreTuning.of(self.params)
        paths_file = self.params.explore_paths_file
        self.explore_paths = load_explore_paths(
            paths_file if paths_file.startswith("/") else config_path(paths_file))
        self.position: np.ndarray | None = None
        self._orientation = (1.0, 0.0, 0.0, 0.0)  # wxyz, ENU <- FLU, of the last odometry
        self.markers_seen: dict[int, int] = {}  # marker id -> last capture stamp [ns]
        self.active = ""  # the running action, for health
        #: how far the last explore goal got, when it was interrupted (canceled by the
        #: mission's HOLD, or a flight error): the next explore goal for the same area,
        #: altitude and markers goes on from there
        self.explore_so_far: ExploreSoFar | None = None
        self.last_message = ""
        self.planner = self.create_client(PLAN_PATH, graph.PLAN_PATH.name)
        self.reach = ActionClient(self, REACH, graph.REACH.name)
        self.fc_takeoff = ActionClient(self, TAKEOFF, graph.TAKEOFF.name)
        self.turn = ActionClient(self, TURN, graph.TURN.name)
        for topic, callback in ((graph.FCU_ODOMETRY, self._on_odometry),
                                (graph.PERCEPTION_MARKERS, self._on_markers)):
            self.create_subscription(topic.type, topic.name, callback, topic.subscriber_qos)
        self.navigate_server = ActionServer(self, NAVIGATE, graph.NAVIGATE.name, self._navigate)
        self.explore_server = ActionServer(self, EXPLORE, graph.EXPLORE.name, self._explore)
        self.takeoff_server = ActionServer(self, TAKEOFF, graph.NAVIGATION_TAKEOFF.name,
                                           self._takeoff)
        health = graph.HEALTH[NODE_NAME]
        self.health_pub = self.create_publisher(health.type, health.name, health.qos)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)

    # -- inputs ------------------------------------------------------------------------
    def _on_odometry(self, msg: Any) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        self.position = np.array([p.x, p.y, p.z])
        self._orientation = (o.w, o.x, o.y, o.z)

    @property
    def yaw(self) -> float:
        """ENU yaw [rad] of the last odometry, worked out when asked (odometry comes far
        more often than the policy steps)."""
        return quat_to_yaw_f(self._orientation)

    def _on_markers(self, msg: Any) -> None:
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        for d in msg.detections:
            self.markers_seen[int(d.id)] = stamp

    def _here(self) -> np.ndarray:
        return self.position.copy() if self.position is not None else np.zeros(3)

    # -- carrying out a policy's commands ----------------------------------------------------
    async def _drive(self, policy: Any, handle: ServerGoalHandle,
                     progress: Callable[[Any], None] | None = None) -> Finish:
        """Step ``policy`` to its :class:`Finish`: each command carried out, its answer (and
        the pose, the time, the cancel request and the markers) fed to the next step."""
        answer: Any = None
        fc: Any = None
        result: Any = None
        while True:
            command = policy.step(Inputs(self.now().nanoseconds, self._here(), self.yaw,
                                         handle.is_cancel_requested, dict(self.markers_seen),
                                         answer))
            answer = None
            match command:
                case Finish():
                    return command
                case Plan(start=start, goal=goal):
                    answer = await self._plan(start, goal)
                case Sleep(seconds=seconds):
                    await self.sleep(seconds)
                case SendReach() | SendTurn():
                    client = self.turn if isinstance(command, SendTurn) else self.reach
                    fc = await client.send_goal_async(flight_goal(command))
                    if fc.accepted:
                        result = fc.get_result_async()
                        answer = Sent(True)
                    else:
                        response = await fc.get_result_async()
                        answer = Sent(False, str(response.result.message))
                case PollAction():
                    r = result.result().result if result.done() else None
                    answer = ActionState(r is not None, r is not None and bool(r.success),
                                         "" if r is None else str(r.message))
                case CancelAction():
                    await fc.cancel_goal_async()
                case NavigateProgress() | ExploreProgress():
                    if progress is not None:
                        progress(command)
                case Log(text=text):
                    self.get_logger().info(text)

    async def _plan(self, start: np.ndarray, goal: np.ndarray) -> Planned:
        """The ``/navigation/plan_path`` answer from ``start`` to ``goal``."""
        response = await self.planner.call_async(plan_request(start, goal))
        return Planned(path_points(response.path) if response.success else None,
                       str(response.message), Time.from_msg(response.path.header.stamp).nanoseconds,
                       int(response.result) in LEG_BLOCKED)

    def _finish(self, handle: ServerGoalHandle, action: Any, code: int, success: bool,
                message: str, **fields: Any) -> Any:
        self.active = ""
        self.last_message = message
        if success:
            handle.succeed()
        elif code == action.Result.RESULT_CANCELED:
            handle.canceled()
        else:
            handle.abort()
        return interfaces.new(action.Result, result=code, success=success, message=message,
                              **fields)

    # -- navigate --------------------------------------------------------------------------
    async def _navigate(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        self.active = "navigate"

        def feedback(progress: NavigateProgress) -> None:
            fb = interfaces.new(NAVIGATE.Feedback, current_waypoint=progress.waypoint,
                                distance_left=progress.distance_left)
            fb.path = path_msg(progress.path, self.now().to_msg())
            handle.publish_feedback(fb)

        policy = NavigatePolicy(self.follow, np.array([goal.goal.x, goal.goal.y, goal.goal.z]),
                                radius=goal.reach_radius or self.params.goal_radius,
                                speed=goal.speed or self.params.cruise_speed, yaw=goal.yaw)
        end = await self._drive(policy, handle, feedback)
        return self._finish(handle, NAVIGATE, NAVIGATE_CODES[end.outcome], end.success,
                            end.message, position=interfaces.point(*self._here()))

    # -- takeoff ---------------------------------------------------------------------------
    async def _takeoff(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        self.active = "takeoff"
        altitude = goal.altitude or self.params.cruise_altitude
        fc = await self.fc_takeoff.send_goal_async(
            interfaces.new(TAKEOFF.Goal, altitude=altitude, speed=goal.speed))
        response = await fc.get_result_async()
        r = response.result
        if not r.success:
            return self._finish(handle, TAKEOFF, int(r.result), False, f"takeoff: {r.message}",
                                position=r.position)
        end = await self._drive(SurveyPolicy(self.params.survey_turns), handle)
        code = TAKEOFF_CODES[end.outcome]
        message = (f"at {altitude:.2f} m, {end.message}" if end.outcome is Outcome.SUCCEEDED
                   else end.message)
        return self._finish(handle, TAKEOFF, code, end.success, message,
                            position=interfaces.point(*self._here()))

    # -- explore ---------------------------------------------------------------------------
    def explore_waypoints(self, area: np.ndarray, altitude: float,
                          sweep: int = 0) -> tuple[np.ndarray, str]:
        """:func:`navigation.navigator_policy.explore_waypoints` from where the vehicle is."""
        return explore_waypoints(self.explore_tuning, self.explore_paths, self.field_min,
                                 self.field_max, area, altitude, self._here(), sweep)

    async def _explore(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        self.active = "explore"
        start_ns = self.now().nanoseconds

        def elapsed() -> Any:
            return Duration(self.now().nanoseconds - start_ns).to_msg()

        def feedback(progress: ExploreProgress) -> None:
            handle.publish_feedback(interfaces.new(
                EXPLORE.Feedback, coverage=progress.coverage, elapsed=elapsed(),
                markers_found=list(progress.markers_found),
                next_waypoint=interfaces.point(*progress.waypoint)))

        policy = ExplorePolicy(
            self.follow, self.explore_tuning,
            area=np.array([[q.x, q.y] for q in goal.area], dtype=np.float64).reshape(-1, 2),
            altitude=goal.altitude or self.params.cruise_altitude, field_min=self.field_min,
            field_max=self.field_max, explore_paths=self.explore_paths, start_ns=start_ns,
            wanted=frozenset(int(i) for i in goal.stop_marker_ids),
            budget_ns=goal.time_budget.sec * 1_000_000_000 + goal.time_budget.nanosec,
            so_far=self.explore_so_far)
        end = await self._drive(policy, handle, feedback)
        assert isinstance(end, ExploreFinish)
        self.explore_so_far = policy.so_far()  # (None unless interrupted)
        return self._finish(handle, EXPLORE, EXPLORE_CODES[end.outcome], end.success,
                            end.message, coverage=end.coverage,
                            markers_found=list(end.markers_found), elapsed=elapsed())

    # -- health ----------------------------------------------------------------------------
    def _publish_health(self) -> None:
        ok = self.position is not None
        self.health_pub.publish(health_report(
            NODE_NAME, MODULE_HEALTH.LEVEL_OK if ok else MODULE_HEALTH.LEVEL_WARN,
            "" if ok else f"no {graph.FCU_ODOMETRY.name} yet",
            {"active": self.active or "idle", "last_message": self.last_message,
             "planner_ready": self.planner.service_is_ready()}, self.now().to_msg()))


__all__ = ["EXPLORE", "NAVIGATE", "TAKEOFF", "NavigatorNode"]
