"""The navigator (seed 003, sec. 3.3.2): takeoff, explore and navigate as actions.

It flies only through the flight-control actions (``/flight_control/takeoff``, ``reach``,
``turn``) and plans only through ``/navigation/plan_path``:

- ``/navigation/navigate``: plan from where the vehicle is to the goal, then follow the
  waypoints with ``reach`` (the flight-control layer interpolates setpoints and applies the
  reach sphere, shrunk at sharp corners so the flown chord cuts a corner by at most
  ``corner_cut``: :mod:`navigation.following`). Before a leg that turns by more than
  ``turn_first_angle`` it stops at the corner and turns to face the leg, so the forward depth
  camera maps what is ahead; then it looks before it goes: it plans again on a map that
  holds a depth cloud captured after the turn (the path's stamp is the map's; it waits up
  to ``map_wait_s`` for one) and switches if the path changed. The camera saw the obstacles
  beside the old leg only side-on, or not at all: a corner planned round as unknown (free)
  space is often in the way once seen. Every ``replan_period_s`` it plans again from here;
  when the leg being flown is no longer clear (the planner cannot go straight to its end)
  or the new path's length differs from what is left of the current one by more than
  ``replan_tolerance`` (the live map changed the path's cost), it switches. When the leg is
  blocked and no new path is found (the goal may turn out to be inside a block whose faces
  the camera had not seen), it stops, plans again ``plan_attempts`` times, then gives up
  with no path. A failed reach is re-planned from where the vehicle is, up to
  ``max_reach_failures``.
- ``/navigation/explore``: the predefined exploration path of the arena and start pad
  (``explore_paths_file``, with loop closures) or, when there is none or the goal gives an
  area, boustrophedon lanes spaced by the down camera's footprint; each leg is planned like
  a navigate goal; a waypoint with no path is skipped or, with
  ``replace_blocked_lane_ends``, replaced by the nearest point toward its lane's other end
  that has one. It stops as soon as one of
  ``stop_marker_ids`` is on ``/perception/markers`` (the vehicle then holds where it is).
  While none is seen, it sweeps again, up to ``explore_sweeps`` times: lanes across the
  area, then along it, in turn. A robot moves while the lanes are flown, and one sweep
  can miss it (random arena 5's robot stayed 1.5-2.3 m beside each lane as the vehicle
  passed); a sweep across the first crosses its track the other way.
- ``/navigation/takeoff``: ``/flight_control/takeoff`` to the cruise altitude, then
  ``survey_turns`` quarter turns so the depth camera maps all around.

Parameters: ``config/navigator.yaml`` (+ ``arena``, ``start_pad`` and the field from the app).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

import interfaces
from flight_control.frames import quat_to_yaw, wrap_pi
from flight_control.health import MODULE_HEALTH, health_report
from flight_control.params import FIELD_SOURCE, FieldParams
from navigation.astar import path_length
from navigation.coverage import (
    CoverageGrid,
    coverage_lanes,
    footprint_half_size,
    lane_spacing,
    load_explore_paths,
)
from navigation.following import corner_radius, turn_angle
from navigation.params import NavigatorParams
from navigation.path_finder_node import PLAN_PATH, PLAN_PATH_SERVICE, path_msg, path_points
from runtime import (
    ActionClient,
    ActionServer,
    Duration,
    Node,
    ParameterError,
    ServerGoalHandle,
    Time,
    qos_profile_default,
    qos_profile_sensor_data,
)
from runtime.parameters import config_path

NAVIGATE = interfaces.get_action("quadmission_interfaces/action/Navigate")
EXPLORE = interfaces.get_action("quadmission_interfaces/action/Explore")
TAKEOFF = interfaces.get_action("quadmission_interfaces/action/Takeoff")
REACH = interfaces.get_action("quadmission_interfaces/action/Reach")
TURN = interfaces.get_action("quadmission_interfaces/action/Turn")
POLL_S = 0.1  # s, how often a running goal looks at its flight-control action
LANE_STEP_M = 0.5  # m, an unreachable explore waypoint is tried this much nearer its lane
LANE_DETOUR = 1.2  # a replacement's path is at most this times the straight line (+ a step)
_PLAN: Any = PLAN_PATH.Response
_LEG_BLOCKED = (_PLAN.RESULT_GOAL_OCCUPIED, _PLAN.RESULT_NO_PATH)  # plan failures that block a leg


class FlyOutcome(Enum):
    REACHED = "reached"
    NO_PATH = "no_path"
    FLIGHT_ERROR = "flight_error"
    CANCELED = "canceled"
    STOPPED = "stopped"  # the caller's stop condition (a marker, a time budget)


@dataclass
class FlyResult:
    outcome: FlyOutcome
    message: str


def _point(x: float, y: float, z: float) -> Any:
    return interfaces.new("geometry_msgs/msg/Point", x=float(x), y=float(y), z=float(z))


class NavigatorNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("navigator", **kwargs)
        self.params = self.declare_params(NavigatorParams)
        try:
            field = self.declare_params(FieldParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        self.field_min = np.asarray(field.field_min, dtype=np.float64)
        self.field_max = np.asarray(field.field_max, dtype=np.float64)
        paths_file = self.params.explore_paths_file
        self.explore_paths = load_explore_paths(
            paths_file if paths_file.startswith("/") else config_path(paths_file))
        self.position: np.ndarray | None = None
        self.yaw = 0.0
        self.markers_seen: dict[int, int] = {}  # marker id -> last capture stamp [ns]
        self.active = ""  # the running action, for health
        self.last_message = ""
        self.planner = self.create_client(PLAN_PATH, PLAN_PATH_SERVICE)
        self.reach = ActionClient(self, REACH, "/flight_control/reach")
        self.fc_takeoff = ActionClient(self, TAKEOFF, "/flight_control/takeoff")
        self.turn = ActionClient(self, TURN, "/flight_control/turn")
        self.create_subscription("nav_msgs/msg/Odometry", "/fcu/odometry", self._on_odometry,
                                 qos_profile_sensor_data)
        self.create_subscription("quadmission_interfaces/msg/MarkerDetectionArray",
                                 "/perception/markers", self._on_markers, qos_profile_default)
        self.navigate_server = ActionServer(self, NAVIGATE, "/navigation/navigate",
                                            self._navigate)
        self.explore_server = ActionServer(self, EXPLORE, "/navigation/explore", self._explore)
        self.takeoff_server = ActionServer(self, TAKEOFF, "/navigation/takeoff", self._takeoff)
        self.health_pub = self.create_publisher("quadmission_interfaces/msg/HealthReport",
                                                "~/health", qos_profile_default)
        self.create_timer(1.0 / self.params.health_rate_hz, self._publish_health)

    # -- inputs ------------------------------------------------------------------------
    def _on_odometry(self, msg: Any) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        self.position = np.array([p.x, p.y, p.z])
        self.yaw = float(quat_to_yaw(np.array([o.w, o.x, o.y, o.z])))

    def _on_markers(self, msg: Any) -> None:
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        for d in msg.detections:
            self.markers_seen[int(d.id)] = stamp

    def _here(self) -> np.ndarray:
        return self.position.copy() if self.position is not None else np.zeros(3)

    # -- flight-control calls ------------------------------------------------------------
    async def _plan(self, start: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray | None, str]:
        path, message, _ = await self._plan_stamped(start, goal)
        return path, message

    async def _ask_planner(self, start: np.ndarray, goal: np.ndarray) -> Any:
        """The ``/navigation/plan_path`` response from ``start`` to ``goal``."""
        request = interfaces.new(PLAN_PATH.Request, start=_point(*start), goal=_point(*goal))
        return await self.planner.call_async(request)

    async def _plan_stamped(self, start: np.ndarray, goal: np.ndarray
                            ) -> tuple[np.ndarray | None, str, int]:
        """(path or None, message, the stamp [ns] of the map it was planned on)."""
        response = await self._ask_planner(start, goal)
        stamp = Time.from_msg(response.path.header.stamp).nanoseconds
        if not response.success:
            return None, str(response.message), stamp
        return path_points(response.path), str(response.message), stamp

    async def _leg_blocked(self, path: np.ndarray, i: int) -> bool:
        """Whether leg ``i`` of ``path`` is no longer clear from here: the planner cannot go
        straight to its end, or says the end is in an obstacle or cut off from here. Not
        when it cannot plan from here at all (the start too close to an obstacle: the
        vehicle is flying out of it), which says nothing of the leg."""
        response = await self._ask_planner(self._here(), path[i])
        if response.success:
            return len(response.path.poses) > 2
        return int(response.result) in _LEG_BLOCKED

    async def _changed_path(self, path: np.ndarray, i: int,
                            new: np.ndarray | None) -> tuple[np.ndarray | None, bool]:
        """(the path to switch to or None, whether leg ``i`` is blocked). ``new`` (a plan
        from here to the goal) is switched to when leg ``i`` of the current path is blocked
        or what is left of it differs from ``new`` in length by more than
        ``replan_tolerance``. A blocked leg with no new path is the caller's to stop on:
        flying on into what the map now shows is how random arena 1 crashed (its
        exploration goal turned out to be inside a block, the re-plan failed, and the old
        path was kept)."""
        blocked = await self._leg_blocked(path, i)
        if new is None:
            return None, blocked
        here = self._here()
        left = float(np.linalg.norm(path[i] - here)) + path_length(path[i:])
        if blocked or abs(path_length(new) - left) > self.params.replan_tolerance:
            return new, blocked
        return None, False

    async def _look_again(self, path: np.ndarray, i: int, goal: np.ndarray,
                          handle: ServerGoalHandle, stop: Any
                          ) -> tuple[np.ndarray | None, bool]:
        """After a turn: plan again on a map holding a depth cloud captured after it (up to
        ``map_wait_s``); :meth:`_changed_path`'s answer on that plan."""
        since_ns = self.now().nanoseconds
        deadline_ns = since_ns + int(self.params.map_wait_s * 1e9)
        while True:
            new, _, stamp = await self._plan_stamped(self._here(), goal)
            if stamp >= since_ns or self.now().nanoseconds >= deadline_ns:
                break
            if handle.is_cancel_requested or (stop is not None and stop()):
                return None, False
            await self.sleep(POLL_S)
        return await self._changed_path(path, i, new)

    async def _plan_again(self, goal: np.ndarray, handle: ServerGoalHandle,
                          stop: Any) -> tuple[np.ndarray | None, str]:
        """The path ahead is blocked and the re-plan found none: hold here and try
        ``plan_attempts`` times, ``replan_period_s`` apart (the map settles as the camera
        looks); (path or None, the last planner message)."""
        await self._hold(handle)
        path: np.ndarray | None = None
        message = ""
        for _ in range(self.params.plan_attempts):
            if handle.is_cancel_requested or (stop is not None and stop()):
                break
            path, message = await self._plan(self._here(), goal)
            if path is not None:
                break
            await self.sleep(self.params.replan_period_s)
        return path, f"the path ahead is blocked and no other path was found: {message}"

    def _reach_goal(self, target: np.ndarray, yaw: float, radius: float, speed: float,
                    stop: bool) -> Any:
        goal = interfaces.new(REACH.Goal, radius=radius, speed=speed, stop_at_target=stop)
        goal.target.position = _point(*target)
        goal.target.orientation = interfaces.new("geometry_msgs/msg/Quaternion", x=0.0, y=0.0,
                                                 z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))
        return goal

    async def _run(self, client: ActionClient, goal: Any, handle: ServerGoalHandle,
                   stop: Any = None) -> tuple[bool | None, str]:
        """Run a flight-control goal to its end: (succeeded, message); (None, why) when
        our goal was canceled or ``stop()`` became true (the flight goal is canceled)."""
        fc = await client.send_goal_async(goal)
        if not fc.accepted:
            response = await fc.get_result_async()
            return False, f"rejected: {response.result.message}"
        result = fc.get_result_async()
        while not result.done():
            if handle.is_cancel_requested or (stop is not None and stop()):
                await fc.cancel_goal_async()
                return None, "canceled" if handle.is_cancel_requested else "stopped"
            await self.sleep(POLL_S)
        r = result.result().result
        return bool(r.success), str(r.message)

    # -- following a planned path --------------------------------------------------------
    async def _fly_to(self, goal: np.ndarray, handle: ServerGoalHandle, *, radius: float,
                      speed: float, stop: Any = None, feedback: Any = None) -> FlyResult:
        """Plan to ``goal`` and follow the path, re-planning as the module docstring says."""
        p = self.params
        path: np.ndarray | None = None
        message = ""
        for _ in range(p.plan_attempts):
            path, message = await self._plan(self._here(), goal)
            if path is not None:
                break
            await self.sleep(p.replan_period_s)
        if path is None:
            return FlyResult(FlyOutcome.NO_PATH, message)
        failures = 0
        i = 1
        while i < len(path):
            wp = path[i]
            last = i == len(path) - 1
            here = self._here()
            heading = math.atan2(wp[1] - here[1], wp[0] - here[0])
            if float(np.hypot(*(wp[:2] - here[:2]))) < 0.3:
                heading = self.yaw
            if abs(wrap_pi(heading - self.yaw)) > p.turn_first_angle:
                ok, why = await self._run(self.turn, interfaces.new(TURN.Goal, yaw=heading),
                                          handle, stop)
                if ok is None:
                    return FlyResult(FlyOutcome.CANCELED if why == "canceled"
                                     else FlyOutcome.STOPPED, why)
                new, blocked = await self._look_again(path, i, goal, handle, stop)
                if new is None and blocked:
                    new, message = await self._plan_again(goal, handle, stop)
                    if new is None:
                        return FlyResult(FlyOutcome.NO_PATH, message)
                if new is not None:
                    path, i = new, 1
                    continue
            # a sharp corner next: stop there (the vehicle turns in place before that leg)
            corner = not last and turn_angle(path, i) > p.turn_first_angle
            radius_i = radius if last else corner_radius(path, i, p.waypoint_radius,
                                                         p.corner_cut)
            fc = await self.reach.send_goal_async(self._reach_goal(
                wp, heading, radius_i, speed, last or corner))
            if not fc.accepted:
                response = await fc.get_result_async()
                return FlyResult(FlyOutcome.FLIGHT_ERROR,
                                 f"reach rejected: {response.result.message}")
            result = fc.get_result_async()
            next_plan_ns = self.now().nanoseconds + int(p.replan_period_s * 1e9)
            switched = False
            while not result.done():
                if handle.is_cancel_requested or (stop is not None and stop()):
                    await fc.cancel_goal_async()
                    return FlyResult(FlyOutcome.CANCELED if handle.is_cancel_requested
                                     else FlyOutcome.STOPPED, "stopped on the way")
                if feedback is not None:
                    feedback(path, i)
                if self.now().nanoseconds >= next_plan_ns:
                    next_plan_ns = self.now().nanoseconds + int(p.replan_period_s * 1e9)
                    new, _ = await self._plan(self._here(), goal)
                    new, blocked = await self._changed_path(path, i, new)
                    if new is not None or blocked:
                        await fc.cancel_goal_async()
                    if new is None and blocked:
                        new, message = await self._plan_again(goal, handle, stop)
                        if new is None:
                            return FlyResult(FlyOutcome.NO_PATH, message)
                    if new is not None:
                        path, i, switched = new, 1, True
                        break
                await self.sleep(POLL_S)
            if switched:
                continue
            r = result.result().result
            if r.success:
                i += 1
                continue
            failures += 1
            if failures > p.max_reach_failures:
                return FlyResult(FlyOutcome.FLIGHT_ERROR, f"reach failed: {r.message}")
            new, message = await self._plan(self._here(), goal)
            if new is None:
                return FlyResult(FlyOutcome.NO_PATH, message)
            path, i = new, 1
        return FlyResult(FlyOutcome.REACHED, "reached")

    # -- navigate --------------------------------------------------------------------------
    async def _navigate(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        R: Any = NAVIGATE.Result
        self.active = "navigate"
        target = np.array([goal.goal.x, goal.goal.y, goal.goal.z])
        radius = goal.reach_radius or self.params.goal_radius
        speed = goal.speed or self.params.cruise_speed

        def feedback(path: np.ndarray, i: int) -> None:
            here = self._here()
            fb = interfaces.new(NAVIGATE.Feedback, current_waypoint=i,
                                distance_left=float(np.linalg.norm(path[i] - here))
                                + path_length(path[i:]))
            fb.path = path_msg(path, self.now().to_msg())
            handle.publish_feedback(fb)

        if not np.all(np.isfinite(target)):
            fly = FlyResult(FlyOutcome.NO_PATH, "goal is not finite")
        else:
            fly = await self._fly_to(target, handle, radius=radius, speed=speed,
                                     feedback=feedback)
        if fly.outcome is FlyOutcome.REACHED and math.isfinite(goal.yaw):
            ok, why = await self._run(self.turn, interfaces.new(TURN.Goal, yaw=goal.yaw), handle)
            if not ok:
                fly = FlyResult(FlyOutcome.CANCELED if ok is None else FlyOutcome.FLIGHT_ERROR,
                                f"final turn: {why}")
        code = {FlyOutcome.REACHED: R.RESULT_OK, FlyOutcome.NO_PATH: R.RESULT_NO_PATH,
                FlyOutcome.FLIGHT_ERROR: R.RESULT_FLIGHT_ERROR,
                FlyOutcome.CANCELED: R.RESULT_CANCELED,
                FlyOutcome.STOPPED: R.RESULT_CANCELED}[fly.outcome]
        return self._finish(handle, NAVIGATE, code, fly.outcome is FlyOutcome.REACHED,
                            fly.message, position=_point(*self._here()))

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

    # -- takeoff ---------------------------------------------------------------------------
    async def _takeoff(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        R: Any = TAKEOFF.Result
        self.active = "takeoff"
        altitude = goal.altitude or self.params.cruise_altitude
        fc = await self.fc_takeoff.send_goal_async(
            interfaces.new(TAKEOFF.Goal, altitude=altitude, speed=goal.speed))
        response = await fc.get_result_async()
        r = response.result
        if not r.success:
            return self._finish(handle, TAKEOFF, int(r.result), False, f"takeoff: {r.message}",
                                position=r.position)
        for q in range(self.params.survey_turns):
            ok, why = await self._run(self.turn, interfaces.new(TURN.Goal, yaw=math.pi / 2.0,
                                                                relative=True), handle)
            if not ok:
                code = R.RESULT_CANCELED if ok is None else R.RESULT_TIMEOUT
                return self._finish(handle, TAKEOFF, code, False,
                                    f"survey turn {q + 1}: {why}", position=_point(*self._here()))
        return self._finish(handle, TAKEOFF, R.RESULT_OK, True,
                            f"at {altitude:.2f} m, {self.params.survey_turns} survey turns",
                            position=_point(*self._here()))

    # -- explore ---------------------------------------------------------------------------
    def explore_waypoints(self, area: np.ndarray, altitude: float,
                          sweep: int = 0) -> tuple[np.ndarray, str]:
        """The explore path (N, 3) for an area ((M, 2) polygon; empty = the field) and where
        it came from. Sweep 0 is the predefined path (when the field has one) or lanes
        along the area's longer side; later sweeps are lanes, across the area (along its
        shorter side) on odd sweeps, each from the corner nearest the vehicle."""
        p = self.params
        across = sweep % 2 == 1
        how = "coverage lanes across" if across else "coverage lanes over"
        if len(area) == 0:
            predefined = self.explore_paths.get(p.arena, {}).get(p.start_pad)
            if predefined is not None and sweep == 0:
                xy, source = predefined, f"explore path of {p.arena} pad {p.start_pad}"
            else:
                lo = self.field_min[:2] + p.wall_margin
                hi = self.field_max[:2] - p.wall_margin
                xy = coverage_lanes(lo, hi, self._spacing(altitude), self._here()[:2],
                                    across=across)
                source = f"{how} the field"
        else:
            xy = coverage_lanes(area.min(axis=0), area.max(axis=0), self._spacing(altitude),
                                self._here()[:2], across=across)
            source = f"{how} the area"
        return np.column_stack([xy, np.full(len(xy), altitude)]), source

    def _spacing(self, altitude: float) -> float:
        p = self.params
        return lane_spacing(altitude, p.down_camera_fovy_deg, p.down_camera_aspect,
                            p.lane_overlap)

    async def _explore(self, handle: ServerGoalHandle) -> Any:
        goal = handle.request
        R: Any = EXPLORE.Result
        p = self.params
        self.active = "explore"
        start_ns = self.now().nanoseconds
        altitude = goal.altitude or p.cruise_altitude
        area = np.array([[q.x, q.y] for q in goal.area], dtype=np.float64).reshape(-1, 2)
        waypoints, source = self.explore_waypoints(area, altitude)
        lo = area.min(axis=0) if len(area) else self.field_min[:2]
        hi = area.max(axis=0) if len(area) else self.field_max[:2]
        grid = CoverageGrid(lo, hi, p.coverage_cell)
        half = footprint_half_size(altitude, p.down_camera_fovy_deg, p.down_camera_aspect)
        wanted = {int(i) for i in goal.stop_marker_ids}
        budget_ns = goal.time_budget.sec * 1_000_000_000 + goal.time_budget.nanosec
        found: list[int] = []
        state = {"budget": False}

        def seen() -> list[int]:
            return sorted(i for i, t in self.markers_seen.items() if t >= start_ns)

        def stop() -> bool:
            here = self._here()
            grid.mark(here[:2], (half[0] * here[2] / altitude, half[1] * here[2] / altitude)
                      if altitude > 0 else half, self.yaw)
            if wanted & set(seen()):
                return True
            if budget_ns and self.now().nanoseconds - start_ns >= budget_ns:
                state["budget"] = True
                return True
            return False

        def elapsed() -> Any:
            return Duration(self.now().nanoseconds - start_ns).to_msg()

        skipped = flown = 0
        outcome: tuple[int, bool, str] | None = None
        stopped = False
        sweeps = p.explore_sweeps if wanted else 1
        for sweep in range(sweeps):
            if sweep:
                waypoints, source = self.explore_waypoints(area, altitude, sweep)
            self.get_logger().info(f"explore sweep {sweep + 1}/{sweeps}: {len(waypoints)} "
                                   f"waypoints ({source})")
            for k, wp in enumerate(waypoints):
                def feedback(_path: np.ndarray, _i: int, wp: np.ndarray = wp) -> None:
                    handle.publish_feedback(interfaces.new(
                        EXPLORE.Feedback, coverage=grid.fraction, elapsed=elapsed(),
                        markers_found=seen(), next_waypoint=_point(*wp)))

                if stop():
                    stopped = True
                    break
                fly = await self._fly_to(wp, handle, radius=p.waypoint_radius,
                                         speed=p.cruise_speed, stop=stop, feedback=feedback)
                if fly.outcome is FlyOutcome.NO_PATH and p.replace_blocked_lane_ends:
                    # the lane's end is in an obstacle: fly the lane as far as it goes
                    partner = k ^ 1 if source.startswith("coverage lanes") else k - 1
                    nearer = (await self._reachable_toward(wp, waypoints[partner])
                              if 0 <= partner < len(waypoints) else None)
                    if nearer is not None:
                        fly = await self._fly_to(nearer, handle, radius=p.waypoint_radius,
                                                 speed=p.cruise_speed, stop=stop,
                                                 feedback=feedback)
                if fly.outcome is FlyOutcome.NO_PATH:
                    skipped += 1
                    continue
                if fly.outcome is FlyOutcome.CANCELED:
                    outcome = (R.RESULT_CANCELED, False, "canceled")
                    break
                if fly.outcome is FlyOutcome.FLIGHT_ERROR:
                    outcome = (R.RESULT_FLIGHT_ERROR, False,
                               f"sweep {sweep + 1}, waypoint {k + 1}: {fly.message}")
                    break
                if fly.outcome is FlyOutcome.STOPPED:
                    stopped = True
                    break
                flown += 1
            if stopped or outcome is not None or stop():
                break
        found = seen()
        if outcome is None:
            if wanted & set(found):
                hit = sorted(wanted & set(found))
                outcome = (R.RESULT_MARKER_FOUND, True, f"marker {hit[0]} found ({source})")
                await self._hold(handle)
            elif state["budget"]:
                outcome = (R.RESULT_TIME_BUDGET, False, "time budget used up")
                await self._hold(handle)
            else:
                outcome = (R.RESULT_COVERED, True,
                           f"{flown}/{flown + skipped} waypoints flown in {sweeps} "
                           f"sweep{'s' * (sweeps > 1)} (last: {source}), {skipped} skipped "
                           "without a path")
        code, success, message = outcome
        return self._finish(handle, EXPLORE, code, success, message, coverage=grid.fraction,
                            markers_found=found, elapsed=elapsed())

    async def _reachable_toward(self, wp: np.ndarray, partner: np.ndarray) -> np.ndarray | None:
        """The point nearest ``wp`` on the segment to ``partner`` (its lane's other end, or
        the path's previous waypoint), in ``LANE_STEP_M`` steps, that the planner reaches
        from here along the lane: by a path at most ``LANE_DETOUR`` times the straight
        line (plus one step), not round the far side of what blocks it. None when none is.
        A lane whose end is inside an obstacle is then still flown up to it: random arena
        6's robot drove between two lanes whose west ends were in blocks; skipping the
        ends skipped the lanes, and a reachable point behind the block made the path cut
        across the field instead of along the lane."""
        length = float(np.linalg.norm(partner - wp))
        here = self._here()
        for d in np.arange(LANE_STEP_M, length, LANE_STEP_M):
            point = wp + (partner - wp) * (d / length)
            path, _ = await self._plan(here, point)
            straight = float(np.linalg.norm(point - here))
            if path is not None and path_length(path) <= LANE_DETOUR * straight + LANE_STEP_M:
                return point
        return None

    async def _hold(self, handle: ServerGoalHandle) -> None:
        """Stop where the vehicle is (a reach to here)."""
        here = self._here()
        await self._run(self.reach, self._reach_goal(here, self.yaw, self.params.goal_radius,
                                                     self.params.cruise_speed, True), handle)

    # -- health ----------------------------------------------------------------------------
    def _publish_health(self) -> None:
        ok = self.position is not None
        self.health_pub.publish(health_report(
            "navigator", MODULE_HEALTH.LEVEL_OK if ok else MODULE_HEALTH.LEVEL_WARN,
            "" if ok else "no /fcu/odometry yet",
            {"active": self.active or "idle", "last_message": self.last_message,
             "planner_ready": self.planner.service_is_ready()}, self.now().to_msg()))


__all__ = ["EXPLORE", "NAVIGATE", "TAKEOFF", "FlyOutcome", "NavigatorNode"]
