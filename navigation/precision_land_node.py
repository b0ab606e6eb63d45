"""The precision-landing action node (seed 003 sec. 3.3.2): ``/navigation/precision_land``.

A goal names a pad (its marker ID) and where the pad should be. The node feeds every
``/perception/markers`` frame to :class:`navigation.precision_landing.PrecisionLander`
(the whole decision, pure) and carries out what it returns, through the flight-control
layer only: ``/flight_control/reach`` to move, ``/flight_control/land`` for the final
landing. With the ``capture`` strategy each measurement is paired with the vehicle's pose
at the image's capture time from ``/fcu/pose_at``; ``seed`` uses the latest
``/fcu/odometry``, as the paper does. It never reads simulator truth.

Results: LANDED, MARKER_NOT_FOUND, MARKER_LOST, FLIGHT_ERROR (a reach or the land
failed), TIMEOUT, CANCELED, each with a message. Feedback at each frame: phase, marker
visible, the (filtered) horizontal error, the reference altitude. Health on ``~/health``.
Parameters: ``config/precision_land.yaml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

import interfaces
from flight_control.health import health_report
from navigation.precision_landing import (
    Fail,
    Failure,
    LandingParams,
    LandingStrategy,
    LandNow,
    Measurement,
    Pose,
    PrecisionLander,
    ReachTo,
)
from runtime import (
    ActionClient,
    ActionServer,
    GoalResponse,
    Node,
    Rejection,
    ServerGoalHandle,
    Time,
    param,
    qos_profile_default,
    qos_profile_sensor_data,
)
from runtime.parameters import validate_parameters

NODE_NAME = "precision_land"
ACTION_NAME = "/navigation/precision_land"
MARKERS_TOPIC = "/perception/markers"
ODOMETRY_TOPIC = "/fcu/odometry"
POSE_AT_SERVICE = "/fcu/pose_at"
SCANNER_ENABLE = "/aruco_scanner/enable"

PRECISION_LAND = interfaces.get_action("quadmission_interfaces/action/PrecisionLand")
REACH = interfaces.get_action("quadmission_interfaces/action/Reach")
LAND = interfaces.get_action("quadmission_interfaces/action/Land")
POSE_AT = interfaces.get_service("quadmission_interfaces/srv/PoseAt")
SET_BOOL = interfaces.get_service("std_srvs/srv/SetBool")
HEALTH: Any = interfaces.get_message("quadmission_interfaces/msg/ModuleHealth")
RESULT: Any = PRECISION_LAND.Result
REACH_RESULT: Any = REACH.Result
_FAILURE_CODE = {Failure.NOT_FOUND: RESULT.RESULT_MARKER_NOT_FOUND,
                 Failure.LOST: RESULT.RESULT_MARKER_LOST, Failure.TIMEOUT: RESULT.RESULT_TIMEOUT}


@dataclass(frozen=True)
class PrecisionLandParams:
    """Parameters of ``precision_land``; values live in ``config/precision_land.yaml``.
    The algorithm's are :class:`LandingParams` field for field."""

    strategy: LandingStrategy  # seed (latest pose) or capture (ours)
    max_tilt: float = param(unit="rad", range=(0.001, 1.0))
    filter_gain: float = param(range=(0.0, 1.0), lo_open=True)
    resolution: float = param(unit="m", range=(0.0, 0.1))
    align_radius: float = param(unit="m", range=(0.001, 1.0))
    max_align_speed: float = param(unit="m/s", range=(0.001, 2.0))
    descent_step: float = param(unit="m", range=(0.01, 2.0))
    min_altitude: float = param(unit="m", range=(0.1, 5.0))
    search_altitude: float = param(unit="m", range=(0.1, 10.0))
    search_spacing: float = param(unit="m", range=(0.05, 5.0))
    search_rings: int = param(range=(0, 10))
    search_timeout_s: float = param(unit="s", range=(0.1, 600.0))
    lost_timeout_s: float = param(unit="s", range=(0.1, 60.0))
    retries: int = param(range=(0, 10))
    timeout_s: float = param(unit="s", range=(1.0, 3600.0))
    outlier_distance: float = param(unit="m", range=(0.01, 5.0))
    height_tolerance: float = param(unit="m", range=(0.01, 5.0))
    max_rejections: int = param(range=(1, 100))
    min_fresh_frames: int = param(range=(1, 100))
    reach_speed: float = param(unit="m/s", range=(0.05, 2.0))
    reach_radius: float = param(unit="m", range=(0.02, 1.0))
    land_speed: float = param(unit="m/s", range=(0.05, 2.0))
    disarm: bool = param(description="disarm once landed")
    max_pad_distance: float = param(unit="m", range=(0.0, 100.0),
                                    description="goals farther than this are rejected")
    health_rate_hz: float = param(unit="Hz", range=(0.1, 10.0))
    poll_s: float = param(unit="s", range=(0.001, 1.0),
                          description="how often the goal looks at new frames")

    def __post_init__(self) -> None:
        validate_parameters(self)
        self.landing()  # cross-field checks

    def landing(self) -> LandingParams:
        names = {f.name for f in fields(LandingParams)}
        return LandingParams(**{n: getattr(self, n) for n in names})


@dataclass(frozen=True)
class _Frame:
    stamp_ns: int
    marker: Measurement | None


def _yaw_roll_pitch(q: Any) -> tuple[float, float, float]:
    w, x, y, z = float(q.w), float(q.x), float(q.y), float(q.z)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    return yaw, roll, pitch


def _pose(pose_msg: Any) -> Pose:
    p = pose_msg.position
    yaw, roll, pitch = _yaw_roll_pitch(pose_msg.orientation)
    return Pose((float(p.x), float(p.y), float(p.z)), yaw, roll, pitch)


class PrecisionLandNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = self.declare_params(PrecisionLandParams)
        self.landing_params = self.params.landing()
        self.odometry: Any = None  # latest /fcu/odometry
        self.frames: list[_Frame] = []
        self.watch_id: int | None = None  # the pad the running goal wants
        self.active = False
        self.last_outcome = ""
        self.reach = ActionClient(self, REACH, "/flight_control/reach")
        self.land = ActionClient(self, LAND, "/flight_control/land")
        self.pose_at = self.create_client(POSE_AT, POSE_AT_SERVICE)
        self.scanner_enable = self.create_client(SET_BOOL, SCANNER_ENABLE)
        self.create_subscription("quadmission_interfaces/msg/MarkerDetectionArray",
                                 MARKERS_TOPIC, self._on_markers, qos_profile_default)
        self.create_subscription("nav_msgs/msg/Odometry", ODOMETRY_TOPIC, self._on_odometry,
                                 qos_profile_sensor_data)
        self.health_pub = self.create_publisher("quadmission_interfaces/msg/HealthReport",
                                                "~/health", qos_profile_default)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)
        self.server = ActionServer(self, PRECISION_LAND, ACTION_NAME, self._execute,
                                   goal_callback=self._check_goal)

    # -- inputs ----------------------------------------------------------------------------
    def _on_odometry(self, msg: Any) -> None:
        self.odometry = msg

    def _on_markers(self, msg: Any) -> None:
        if self.watch_id is None:
            return
        marker = None
        for d in msg.detections:
            if int(d.id) == self.watch_id:
                marker = Measurement((float(d.offset_x), float(d.offset_y)), float(d.height))
                break
        self.frames.append(_Frame(Time.from_msg(msg.header.stamp).nanoseconds, marker))

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
            return Rejection(f"no {ODOMETRY_TOPIC} yet: where is the vehicle?")
        pad = goal.pad_position
        values = (float(pad.x), float(pad.y), float(pad.z))
        if not all(math.isfinite(v) for v in values):
            return Rejection(f"pad_position {values} is not finite")
        distance = math.hypot(values[0] - latest[0].position[0],
                              values[1] - latest[0].position[1])
        if self.params.max_pad_distance > 0.0 and distance > self.params.max_pad_distance:
            return Rejection(f"pad {goal.pad_id} is {distance:.2f} m away (more than "
                             f"{self.params.max_pad_distance:g} m): navigate there first")
        height = latest[0].position[2] - values[2]
        if height < self.params.min_altitude - 0.2:
            return Rejection(f"the vehicle is {height:.2f} m above the pad: take off first "
                             f"(at least {self.params.min_altitude:g} m)")
        return GoalResponse.ACCEPT

    def _result(self, handle: ServerGoalHandle, code: int, message: str,
                lander: PrecisionLander | None, position: Any = None) -> Any:
        success = code == RESULT.RESULT_LANDED
        if success:
            handle.succeed()
        elif code == RESULT.RESULT_CANCELED:
            handle.canceled()
        else:
            handle.abort()
        error = lander.error if lander is not None and lander.error is not None else None
        result = interfaces.new(
            RESULT, result=int(code), success=success, message=message,
            lateral_error=float(np.hypot(*error)) if error is not None else math.nan)
        if position is not None:
            result.position = position
        elif (latest := self._latest()) is not None:
            x, y, z = latest[0].position
            result.position = interfaces.new("geometry_msgs/msg/Point", x=x, y=y, z=z)
        self.active = False
        self.watch_id = None
        self.last_outcome = message
        self.get_logger().info(f"precision_land: {message}")
        return result

    async def _pose_at(self, stamp_ns: int) -> Pose | None:
        response = await self.pose_at.call_async(
            interfaces.new(POSE_AT.Request, stamp=Time(stamp_ns).to_msg()))
        if not response.success:
            return None
        return _pose(response.odometry.pose.pose)

    def _reach_goal(self, target: tuple[float, float, float], yaw: float) -> Any:
        goal = interfaces.new(REACH.Goal, stop_at_target=True, speed=self.params.reach_speed,
                              radius=self.params.reach_radius)
        goal.target.position = interfaces.new("geometry_msgs/msg/Point", x=target[0],
                                              y=target[1], z=target[2])
        goal.target.orientation = interfaces.new("geometry_msgs/msg/Quaternion",
                                                 w=math.cos(yaw / 2.0), z=math.sin(yaw / 2.0))
        return goal

    async def _execute(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        pad = (float(goal.pad_position.x), float(goal.pad_position.y),
               float(goal.pad_position.z))
        params = self.landing_params
        if goal.search_radius > 0.0:  # as many rings as cover the radius
            rings = max(1, math.ceil(goal.search_radius / params.search_spacing))
            params = replace(params, search_rings=rings)
        start = self._latest()
        assert start is not None  # checked by the goal callback
        lander = PrecisionLander(params, pad, self.params.strategy,
                                 start_s=self.now().nanoseconds / 1e9)
        lander.start(start[0].position)
        hold_yaw = start[0].yaw
        self.active = True
        self.watch_id = int(goal.pad_id)
        self.frames = []
        if self.scanner_enable.service_is_ready():
            self.scanner_enable.call_async(interfaces.new(SET_BOOL.Request, data=True))
        reach_result: Any = None  # the running reach's result future
        capture = self.params.strategy is LandingStrategy.CAPTURE
        while True:
            if handle.is_cancel_requested:
                return self._result(handle, RESULT.RESULT_CANCELED, "canceled", lander)
            if reach_result is not None and reach_result.done():
                r = reach_result.result().result
                reach_result = None
                if not r.success and r.result == REACH_RESULT.RESULT_TIMEOUT:
                    # a correction that stalls just outside its small sphere (seen: 3.0 cm
                    # from the target, radius 3 cm) is no flight error: the next frame
                    # measures again from where the vehicle is, within the landing's timeouts
                    self.get_logger().warn(f"precision_land: correction move: {r.message}")
                elif not r.success:
                    return self._result(handle, RESULT.RESULT_FLIGHT_ERROR,
                                        f"reach failed: {r.message}", lander)
            frames, self.frames = self.frames, []
            if not frames and self.now().nanoseconds / 1e9 - lander.start_s > params.timeout_s:
                return self._result(handle, RESULT.RESULT_TIMEOUT,
                                    f"pad {goal.pad_id}: no marker frames for "
                                    f"{params.timeout_s:g} s (is the scanner running?)", lander)
            for frame in frames:
                latest = self._latest()
                assert latest is not None
                pose = latest[0]
                if capture and frame.marker is not None:
                    at = await self._pose_at(frame.stamp_ns)
                    if at is None:
                        continue
                    pose = at
                command = lander.on_frame(self.now().nanoseconds / 1e9, frame.marker, pose,
                                          latest[0].position, latest[1],
                                          busy=reach_result is not None)
                self._feedback(handle, lander, frame.marker is not None)
                if isinstance(command, Fail):
                    return self._result(handle, _FAILURE_CODE[command.failure],
                                        f"pad {goal.pad_id}: {command.failure.value}: "
                                        f"{command.message}", lander)
                if isinstance(command, ReachTo):
                    reach = await self.reach.send_goal_async(
                        self._reach_goal(command.position, hold_yaw))
                    if not reach.accepted:
                        rejected = await reach.get_result_async()
                        return self._result(handle, RESULT.RESULT_FLIGHT_ERROR,
                                            f"reach rejected: {rejected.result.message}", lander)
                    reach_result = reach.get_result_async()
                    break  # frames queued before the move are stale
                if isinstance(command, LandNow):
                    return await self._final_land(handle, lander, goal.pad_id)
            await self.sleep(self.params.poll_s)

    async def _final_land(self, handle: ServerGoalHandle, lander: PrecisionLander,
                          pad_id: int) -> Any:
        self._feedback(handle, lander, True)
        land = await self.land.send_goal_async(
            interfaces.new(LAND.Goal, speed=self.params.land_speed, disarm=self.params.disarm))
        response = await land.get_result_async()
        r = response.result
        if not land.accepted or not r.success:
            return self._result(handle, RESULT.RESULT_FLIGHT_ERROR, f"land failed: {r.message}",
                                lander)
        return self._result(handle, RESULT.RESULT_LANDED, f"landed on pad {pad_id}", lander,
                            position=r.position)

    def _feedback(self, handle: ServerGoalHandle, lander: PrecisionLander,
                  visible: bool) -> None:
        error = lander.error
        handle.publish_feedback(interfaces.new(
            PRECISION_LAND.Feedback, phase=int(lander.phase.value), marker_visible=visible,
            lateral_error=float(np.hypot(*error)) if error is not None else math.nan,
            altitude=float(lander.reference_altitude)))

    # -- health ----------------------------------------------------------------------------
    def _publish_health(self) -> None:
        now = self.now()
        problems = [] if self.odometry is not None else [f"no {ODOMETRY_TOPIC}"]
        if not self.reach.server_is_ready():
            problems.append("no /flight_control/reach server")
        if not self.pose_at.service_is_ready():
            problems.append(f"no {POSE_AT_SERVICE} service")
        level = HEALTH.LEVEL_ERROR if problems else HEALTH.LEVEL_OK
        values = {"strategy": self.params.strategy.value, "active": str(self.active).lower(),
                  "last_outcome": self.last_outcome}
        self.health_pub.publish(health_report(NODE_NAME, level, "; ".join(problems), values,
                                              now.to_msg()))


__all__ = ["ACTION_NAME", "NODE_NAME", "PrecisionLandNode", "PrecisionLandParams"]
