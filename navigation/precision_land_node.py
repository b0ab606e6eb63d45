"""The precision-landing action node (seed 003 sec. 3.3.2): ``/navigation/precision_land``.

A goal names a pad (its marker ID) and where the pad should be. The node feeds every
``/perception/markers`` frame, each move's and the land's end, and a cancel to
:class:`navigation.precision_land_policy.PrecisionLandPolicy` (the whole decision, pure,
around the seed's step :class:`navigation.precision_landing.PrecisionLander`) and
carries out what it returns, through the flight-control layer only:
``/flight_control/reach`` to move, ``/flight_control/land`` for the final landing; each
leg of the pad search is first checked on ``/navigation/plan_path`` (the navigator's
request, so its clearance; without a path finder the search flies as it is). With
the ``capture`` strategy each measurement is paired with the vehicle's pose at the
image's capture time from ``/fcu/pose_at``; ``seed`` uses the latest ``/fcu/odometry``,
as the paper does. It never reads simulator truth.

Results: LANDED, MARKER_NOT_FOUND, MARKER_LOST, FLIGHT_ERROR (a reach or the land
failed), TIMEOUT, CANCELED (also while it waits on a node that died). Feedback: phase,
marker visible, horizontal error, reference altitude. Parameters: :class:`PrecisionLandParams`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import quat_to_yaw_roll_pitch
from flight_control.health import health_report
from flight_control.policy import Finish, Outcome
from interfaces import graph
from navigation.navigator_messages import plan_request
from navigation.params import PrecisionLandParams
from navigation.path_finder_node import PLAN_PATH, path_points
from navigation.precision_land_policy import (
    CheckLeg,
    Move,
    PlanAnswer,
    PrecisionLandPolicy,
    Touchdown,
    goal_problem,
    pad_marker,
)
from navigation.precision_landing import Measurement, Pose
from runtime import (
    ActionClient,
    ActionServer,
    GoalCanceled,
    GoalResponse,
    Node,
    Rejection,
    ServerGoalHandle,
    Time,
)

NODE_NAME = "precision_land"

PRECISION_LAND = graph.PRECISION_LAND.interface()
REACH = graph.REACH.interface()
LAND = graph.LAND.interface()
POSE_AT = graph.POSE_AT.interface()
SET_BOOL = graph.SCANNER_ENABLE.interface()
HEALTH: Any = interfaces.get_message("quadmission_interfaces/msg/ModuleHealth")
RESULT: Any = PRECISION_LAND.Result
REACH_RESULT: Any = REACH.Result
_PLAN: Any = PLAN_PATH.Response
#: Plan failures that say a search point is not to be flown to; any other says nothing.
SEARCH_POINT_BLOCKED = (_PLAN.RESULT_GOAL_OCCUPIED, _PLAN.RESULT_NO_PATH,
                         _PLAN.RESULT_OUT_OF_BOUNDS)
#: How the policy ended (:data:`~navigation.precision_land_policy.PRECISION_LAND_OUTCOMES`)
#: -> the PrecisionLand result code; ``success`` is :attr:`Finish.success`.
PRECISION_LAND_CODES = {Outcome.SUCCEEDED: RESULT.RESULT_LANDED,
                        Outcome.MARKER_NOT_FOUND: RESULT.RESULT_MARKER_NOT_FOUND,
                        Outcome.MARKER_LOST: RESULT.RESULT_MARKER_LOST,
                        Outcome.FLIGHT_ERROR: RESULT.RESULT_FLIGHT_ERROR,
                        Outcome.TIMEOUT: RESULT.RESULT_TIMEOUT,
                        Outcome.CANCELED: RESULT.RESULT_CANCELED}


def _point(point_msg: Any) -> tuple[float, float, float]:
    return float(point_msg.x), float(point_msg.y), float(point_msg.z)


def _pose(pose_msg: Any) -> Pose:
    p, q = pose_msg.position, pose_msg.orientation
    yaw, roll, pitch = quat_to_yaw_roll_pitch((float(q.w), float(q.x), float(q.y), float(q.z)))
    return Pose((float(p.x), float(p.y), float(p.z)), yaw, roll, pitch)


class PrecisionLandNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(PrecisionLandParams)
        self.landing_params = self.params.landing()
        self.odometry: Any = None  # latest /fcu/odometry
        self.frames: list[tuple[int, Measurement | None]] = []  # (capture stamp [ns], marker)
        self.watch_id: int | None = None  # the pad the running goal wants
        self.active = False
        self.last_outcome = ""
        self.reach = ActionClient(self, REACH, graph.REACH.name)
        self.land = ActionClient(self, LAND, graph.LAND.name)
        self.pose_at = self.create_client(POSE_AT, graph.POSE_AT.name)
        self.scanner_enable = self.create_client(SET_BOOL, graph.SCANNER_ENABLE.name)
        self.planner = self.create_client(PLAN_PATH, graph.PLAN_PATH.name)
        for topic, callback in ((graph.PERCEPTION_MARKERS, self._on_markers),
                                (graph.FCU_ODOMETRY, self._on_odometry)):
            self.create_subscription(topic.type, topic.name, callback, topic.subscriber_qos)
        health = graph.HEALTH[NODE_NAME]
        self.health_pub = self.create_publisher(health.type, health.name, health.qos)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)
        self.server = ActionServer(self, PRECISION_LAND, graph.PRECISION_LAND.name, self._execute,
                                   goal_callback=self._check_goal)

    def _on_odometry(self, msg: Any) -> None:
        self.odometry = msg

    def _on_markers(self, msg: Any) -> None:
        if self.watch_id is None:
            return
        marker = pad_marker(((int(d.id), Measurement((float(d.offset_x), float(d.offset_y)),
                                                     float(d.height)))
                             for d in msg.detections), self.watch_id)
        self.frames.append((Time.from_msg(msg.header.stamp).nanoseconds, marker))

    def _latest(self) -> tuple[Pose, float] | None:
        """The latest pose and horizontal speed [m/s], or None before any odometry."""
        if self.odometry is None:
            return None
        v = self.odometry.twist.twist.linear
        return _pose(self.odometry.pose.pose), math.hypot(float(v.x), float(v.y))

    # -- goals -----------------------------------------------------------------------------
    def _check_goal(self, goal: Any) -> Any:
        if self.active:
            return Rejection("a precision landing is already running")
        latest = self._latest()
        if latest is None:
            return Rejection(f"no {graph.FCU_ODOMETRY.name} yet: where is the vehicle?")
        problem = goal_problem(goal.pad_id, _point(goal.pad_position), latest[0].position,
                               max_pad_distance=self.params.max_pad_distance,
                               min_altitude=self.params.min_altitude)
        return GoalResponse.ACCEPT if problem is None else Rejection(problem)

    def _result(self, handle: ServerGoalHandle, finish: Finish, policy: PrecisionLandPolicy,
                position: Any = None) -> Any:
        if finish.success:
            handle.succeed()
        elif finish.outcome is Outcome.CANCELED:
            handle.canceled()
        else:
            handle.abort()
        result = interfaces.new(RESULT, result=PRECISION_LAND_CODES[finish.outcome],
                                success=finish.success, message=finish.message,
                                lateral_error=policy.lateral_error)
        if position is not None:
            result.position = position
        elif (latest := self._latest()) is not None:
            result.position = interfaces.point(*latest[0].position)
        self.active = False
        self.watch_id = None
        self.last_outcome = finish.message
        self.get_logger().info(f"precision_land: {finish.message}")
        return result

    async def _pose_at(self, handle: ServerGoalHandle, stamp_ns: int) -> Pose | None:
        response = await handle.unless_canceled(self.pose_at.call_async(
            interfaces.new(POSE_AT.Request, stamp=Time(stamp_ns).to_msg())))
        if not response.success:
            return None
        return _pose(response.odometry.pose.pose)

    async def _plan_leg(self, handle: ServerGoalHandle, check: CheckLeg) -> tuple[PlanAnswer, Any]:
        """The path finder's answer to a search leg (UNKNOWN without a path finder)."""
        if not self.planner.service_is_ready():
            return PlanAnswer.UNKNOWN, None
        request = plan_request(np.array(check.start), np.array(check.goal))
        r = await handle.unless_canceled(self.planner.call_async(request))
        if r.success:
            return PlanAnswer.PATH, path_points(r.path)
        return (PlanAnswer.BLOCKED if int(r.result) in SEARCH_POINT_BLOCKED
                else PlanAnswer.UNKNOWN), None

    def _reach_goal(self, move: Move) -> Any:
        goal = interfaces.new(REACH.Goal, stop_at_target=True, speed=self.params.reach_speed,
                              radius=self.params.reach_radius)
        goal.target.position = interfaces.point(*move.position)
        goal.target.orientation = interfaces.new("geometry_msgs/msg/Quaternion",
                                                 w=math.cos(move.yaw / 2.0),
                                                 z=math.sin(move.yaw / 2.0))
        return goal

    async def _execute(self, handle: ServerGoalHandle) -> Any:
        policy = self._start(handle)
        try:
            return await self._run(handle, policy)
        except GoalCanceled:  # while it waited on a node (that may have died)
            return self._result(handle, policy.cancel(), policy)

    def _start(self, handle: ServerGoalHandle) -> PrecisionLandPolicy:
        goal, start = handle.request, self._latest()
        assert start is not None  # checked by the goal callback
        policy = PrecisionLandPolicy(self.landing_params, self.params.strategy,
                                     int(goal.pad_id), _point(goal.pad_position), start[0],
                                     self.now().nanoseconds,
                                     search_radius=float(goal.search_radius))
        self.active = True
        self.watch_id = int(goal.pad_id)
        self.frames = []
        if self.scanner_enable.service_is_ready() and not handle.is_cancel_requested:
            self.scanner_enable.call_async(interfaces.new(SET_BOOL.Request, data=True))
        return policy

    async def _run(self, handle: ServerGoalHandle, policy: PrecisionLandPolicy) -> Any:
        reach_result: Any = None  # the running reach's result future
        while True:
            if handle.is_cancel_requested:
                return self._result(handle, policy.cancel(), policy)
            if reach_result is not None and reach_result.done():
                r = reach_result.result().result
                reach_result = None
                ended = policy.reach_ended(r.success, r.result == REACH_RESULT.RESULT_TIMEOUT,
                                           r.message, self.now().nanoseconds)
                if isinstance(ended, Finish):
                    return self._result(handle, ended, policy)
                if ended.why:
                    self.get_logger().warn(f"precision_land: {ended.why}")
            frames, self.frames = self.frames, []
            if (timeout := policy.poll(self.now().nanoseconds, bool(frames))) is not None:
                return self._result(handle, timeout, policy)
            for stamp_ns, marker in frames:
                latest = self._latest()
                assert latest is not None
                pose: Pose | None = latest[0]
                if policy.needs_capture_pose(marker):
                    pose = await self._pose_at(handle, stamp_ns)
                if pose is None:
                    continue  # no pose at its capture time: the frame says nothing
                command = policy.frame(self.now().nanoseconds, marker, pose,
                                       latest[0].position, latest[1], stamp_ns)
                while isinstance(command, CheckLeg):
                    answer = await self._plan_leg(handle, command)
                    command = policy.leg_planned(command, *answer, self.now().nanoseconds)
                    if policy.leg_note:
                        self.get_logger().info(f"precision_land: {policy.leg_note}")
                self._feedback(handle, policy, marker is not None)
                if isinstance(command, Finish):
                    return self._result(handle, command, policy)
                if isinstance(command, Move):
                    sent = self.reach.send_goal_async(self._reach_goal(command))
                    reach = await handle.unless_canceled(sent)
                    if reach.accepted:
                        reach_result = reach.get_result_async()
                        break  # frames queued before the move are stale
                    rejected = await handle.unless_canceled(reach.get_result_async())
                    refused = policy.reach_rejected(rejected.result.message)
                    if isinstance(refused, Finish):
                        return self._result(handle, refused, policy)
                    self.get_logger().warn(f"precision_land: {refused.why}")
                    break
                if isinstance(command, Touchdown):
                    return await self._final_land(handle, policy)
            await self.sleep(self.params.poll_s)

    async def _final_land(self, handle: ServerGoalHandle, policy: PrecisionLandPolicy) -> Any:
        self._feedback(handle, policy, True)
        land = await handle.unless_canceled(self.land.send_goal_async(
            interfaces.new(LAND.Goal, speed=self.params.land_speed, disarm=self.params.disarm)))
        r = (await handle.unless_canceled(land.get_result_async())).result
        finish = policy.land_ended(land.accepted and r.success, r.message)
        return self._result(handle, finish, policy,
                            position=r.position if finish.success else None)

    def _feedback(self, handle: ServerGoalHandle, policy: PrecisionLandPolicy,
                  visible: bool) -> None:
        handle.publish_feedback(interfaces.new(
            PRECISION_LAND.Feedback, phase=int(policy.phase.value), marker_visible=visible,
            lateral_error=policy.lateral_error, altitude=float(policy.reference_altitude)))

    # -- health ----------------------------------------------------------------------------
    def _publish_health(self) -> None:
        now = self.now()
        problems = [] if self.odometry is not None else [f"no {graph.FCU_ODOMETRY.name}"]
        if not self.reach.server_is_ready():
            problems.append(f"no {graph.REACH.name} server")
        if not self.pose_at.service_is_ready():
            problems.append(f"no {graph.POSE_AT.name} service")
        level = HEALTH.LEVEL_ERROR if problems else HEALTH.LEVEL_OK
        values = {"strategy": self.params.strategy.value, "active": str(self.active).lower(),
                  "last_outcome": self.last_outcome}
        self.health_pub.publish(health_report(NODE_NAME, level, "; ".join(problems), values,
                                              now.to_msg()))


__all__ = ["NODE_NAME", "PrecisionLandNode", "PrecisionLandParams"]
