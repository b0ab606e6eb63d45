"""The mission node: :class:`~fsm.mission_driver.Driver` (the mission machine and the
policy that drives it) wired to the stack's interfaces. It converts messages into the
driver's inputs, carries out its commands and feeds the answers back; the decisions
(what follows a result, the alerts, the timeouts, the error policy) are the driver's.

- actions: ``/navigation/takeoff`` from the start pad (it maps around after the climb),
  ``/flight_control/takeoff`` from the sequence's pads, ``/flight_control/land`` (with
  ``/flight_control/arm``), ``/flight_control/reach`` (a take-off resumed in the air),
  ``/navigation/explore``, ``navigate`` and ``precision_land``; a goal whose job ended
  is canceled (cancel reaches the active child) and its late result dropped;
- ``/mission/command`` (MissionCommand), answered on ``/mission/events`` (MissionEvent);
- ``/mission/state`` (MissionState) on every change and at ``state_rate_hz``;
- ``/mission/robot`` (RobotFound): the pictures of the target robot;
- ``/aruco_scanner/enable`` (SetBool): the scanner on in the states that read markers,
  off in the others (:func:`fsm.mission_table.scans`), asked on each change and again at
  each watchdog tick until the scanner has answered that it is so;
- inputs of the alerts, checked at ``watchdog_rate_hz``: ``/fcu/status`` and each of
  ``health_topics``; preflight also needs every action of ``action_servers``;
  ``/fcu/odometry`` gives the position (a take-off resumed in the air, the robot's
  position when no picture came).

``timeline`` and ``events`` keep what happened, with the companion time, for reports.
"""

from __future__ import annotations

import math
from dataclasses import fields
from functools import partial
from typing import Any

import interfaces
from flight_control.clients import arm, arm_client
from flight_control.policy import Outcome
from fsm import mission_driver as d
from fsm.mission_machine import Mission, MissionConfig, MissionEvent
from fsm.mission_table import phase_of, scans
from fsm.params import FIELD_SOURCE, MissionParams, PadsParams
from perception.names import SCANNER_ENABLE_SERVICE
from runtime import (
    ActionClient,
    Duration,
    Node,
    ParameterError,
    QoSProfile,
    Time,
    qos_profile_default,
    qos_profile_latched,
    qos_profile_sensor_data,
)
from runtime.action import ClientGoalHandle, GoalStatus

QM = "quadmission_interfaces"
TAKEOFF = interfaces.get_action(f"{QM}/action/Takeoff")
LAND = interfaces.get_action(f"{QM}/action/Land")
REACH = interfaces.get_action(f"{QM}/action/Reach")
EXPLORE = interfaces.get_action(f"{QM}/action/Explore")
NAVIGATE = interfaces.get_action(f"{QM}/action/Navigate")
PRECISION_LAND = interfaces.get_action(f"{QM}/action/PrecisionLand")
EXPLORE_RESULT: Any = EXPLORE.Result
NAVIGATE_RESULT: Any = NAVIGATE.Result
LAND_RESULT: Any = PRECISION_LAND.Result
COMMAND: Any = interfaces.get_message(f"{QM}/msg/MissionCommand")
STATE: Any = interfaces.get_message(f"{QM}/msg/MissionState")
EVENT: Any = interfaces.get_message(f"{QM}/msg/MissionEvent")
HEALTH: Any = interfaces.get_message(f"{QM}/msg/ModuleHealth")
ROBOT = f"{QM}/msg/RobotFound"
SET_BOOL = interfaces.get_service("std_srvs/srv/SetBool")

STATE_TOPIC = "/mission/state"
EVENTS_TOPIC = "/mission/events"
COMMAND_TOPIC = "/mission/command"
ROBOT_TOPIC = "/mission/robot"
#: The operator's optimal landing sequence as it proposes it (the ground station's editor
#: starts from it), latched, before it sends the sequence on the command topic.
PROPOSAL_TOPIC = "/mission/sequence_proposal"
#: Late joiners (a ground station page opened mid-run) get the latest state and pictures.
LATCHED = qos_profile_latched
EVENTS_QOS = QoSProfile(depth=100)

ACTIONS: dict[d.Action, tuple[Any, str]] = {
    d.Action.SURVEY_TAKEOFF: (TAKEOFF, "/navigation/takeoff"),
    d.Action.TAKEOFF: (TAKEOFF, "/flight_control/takeoff"),
    d.Action.LAND: (LAND, "/flight_control/land"),
    d.Action.REACH: (REACH, "/flight_control/reach"),
    d.Action.EXPLORE: (EXPLORE, "/navigation/explore"),
    d.Action.NAVIGATE: (NAVIGATE, "/navigation/navigate"),
    d.Action.PRECISION_LAND: (PRECISION_LAND, "/navigation/precision_land"),
}
#: Result codes that are not a plain success or failure, per action.
OUTCOMES: dict[d.Action, dict[int, Outcome]] = {
    d.Action.EXPLORE: {EXPLORE_RESULT.RESULT_MARKER_FOUND: Outcome.SUCCEEDED,
                       EXPLORE_RESULT.RESULT_COVERED: Outcome.COVERED,
                       EXPLORE_RESULT.RESULT_TIME_BUDGET: Outcome.TIME_BUDGET},
    d.Action.NAVIGATE: {NAVIGATE_RESULT.RESULT_NO_PATH: Outcome.NO_PATH},
    d.Action.PRECISION_LAND: {LAND_RESULT.RESULT_MARKER_NOT_FOUND: Outcome.MARKER_NOT_FOUND,
                              LAND_RESULT.RESULT_MARKER_LOST: Outcome.MARKER_LOST},
}
ORDERS = {getattr(COMMAND, f"COMMAND_{order.name}"): order for order in d.Order}


class MissionNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("mission", **kwargs)
        self.params = p = self.declare_params(MissionParams)
        try:
            pads = self.declare_params(PadsParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        self.driver = d.Driver(MissionConfig(
            target_robot=p.target_robot, start_pad=pads.start_pad, pads=pads.positions(),
            search_radius_near=p.search_radius_near, search_radius_wide=p.search_radius_wide),
            d.DriverParams(**{f.name: getattr(p, f.name) for f in fields(d.DriverParams)}),
            self.now().nanoseconds)
        self.mission: Mission = self.driver.mission
        self.timeline: list[tuple[float, str]] = self.driver.timeline
        self.events: list[tuple[float, MissionEvent]] = self.driver.events
        self._active: tuple[ActionClient, ClientGoalHandle] | None = None

        self.arm_client = arm_client(self)
        self.scanner_enable = self.create_client(SET_BOOL, SCANNER_ENABLE_SERVICE)
        self._scan_wanted = scans(self.mission.state)
        self._scan_answered: bool | None = None  # what the scanner last said it does
        self._scan_asked: Any = None  # the request in flight
        self.clients = {action: ActionClient(self, kind, topic)
                        for action, (kind, topic) in ACTIONS.items()}
        self.state_pub = self.create_publisher(STATE, STATE_TOPIC, LATCHED)
        self.event_pub = self.create_publisher(EVENT, EVENTS_TOPIC, EVENTS_QOS)
        self.robot_pub = self.create_publisher(ROBOT, ROBOT_TOPIC, LATCHED)
        self.create_subscription(COMMAND, COMMAND_TOPIC, self._on_command, qos_profile_default)
        self.create_subscription(ROBOT, "/perception/robot_found", self._on_robot,
                                 qos_profile_default)
        self.create_subscription(f"{QM}/msg/FcuStatus", "/fcu/status", self._on_status,
                                 qos_profile_default)
        self.create_subscription("nav_msgs/msg/Odometry", "/fcu/odometry", self._on_odometry,
                                 qos_profile_sensor_data)
        for topic in p.health_topics:
            self.create_subscription(f"{QM}/msg/HealthReport", topic,
                                     partial(self._on_health, topic), qos_profile_default)
        self.create_timer(1.0 / p.state_rate_hz, self.publish_state)
        self.create_timer(1.0 / p.watchdog_rate_hz, self._watchdog)
        self.publish_state()

    # -- messages in -----------------------------------------------------------------------
    def _on_command(self, msg: Any) -> None:
        order, seq = ORDERS.get(int(msg.command)), msg.sequence
        self._feed(d.UnknownCommand(int(msg.command)) if order is None else d.OperatorCommand(
            order, str(msg.reason), tuple(int(p) for p in seq.pad_ids),
            tuple(int(p) for p in seq.pad_points)))

    def _on_robot(self, msg: Any) -> None:
        self._feed(d.RobotSeen(int(msg.marker_id), msg))

    def _on_status(self, msg: Any) -> None:
        self._feed(d.VehicleStatus(bool(msg.position_valid), bool(msg.armed), bool(msg.landed),
                                   int(msg.battery_warning), float(msg.battery_remaining),
                                   bool(msg.failsafe)))

    def _on_odometry(self, msg: Any) -> None:
        p = msg.pose.pose.position
        self._feed(d.Position((float(p.x), float(p.y), float(p.z))))

    def _on_health(self, topic: str, msg: Any) -> None:
        level = int(msg.level)
        self._feed(d.Health(topic, level == HEALTH.LEVEL_OK, level >= HEALTH.LEVEL_ERROR,
                            "; ".join(str(h.message) for h in msg.modules if h.message)))

    def _watchdog(self) -> None:
        self._feed(d.Tick())
        if self._scan_answered is not self._scan_wanted:
            self._ask_scanner()

    def _ask_scanner(self) -> None:
        """Ask the scanner to be as the state wants it, unless a request is in flight or
        the service is not up yet (the watchdog asks again)."""
        if (self._scan_asked is not None and not self._scan_asked.done()) \
                or not self.scanner_enable.service_is_ready():
            return
        wanted = self._scan_wanted
        self._scan_asked = future = self.scanner_enable.call_async(
            interfaces.new(SET_BOOL.Request, data=wanted))

        def answered(f: Any) -> None:
            if not f.cancelled() and f.exception() is None and f.result().success \
                    and wanted is self._scan_wanted:
                self._scan_answered = wanted
        future.add_done_callback(answered)

    # -- the driver's commands -------------------------------------------------------------
    def _feed(self, event: d.Input, job: int | None = None) -> d.Job | None:
        """Give ``event`` to the driver and carry out its commands; the one that continues
        ``job`` is returned (its task awaits it), the others run at once or in a new task."""
        follow: d.Job | None = None
        for c in self.driver.step(event, self.now().nanoseconds):
            if isinstance(c, d.JOBS):
                if c.job == job:
                    follow = c
                else:
                    self.create_task(self._job(c))
            elif isinstance(c, d.PublishEvent):
                self._publish_event(c.event, c.state)
            elif isinstance(c, d.StateChanged):
                self.state_changed(c.state)
            elif isinstance(c, d.PublishState):
                self._publish_state(c.snapshot)
            elif isinstance(c, d.SendPictures):
                for picture in c.pictures:
                    self.robot_pub.publish(self._robot_msg(picture))
            else:
                self._cancel_goal()
        return follow

    async def _job(self, command: d.Job) -> None:
        c: d.Job | None = command
        while c is not None:
            reply = await self._carry_out(c)
            if reply is None:
                return
            c = self._feed(reply, c.job)

    async def _carry_out(self, c: d.Job) -> d.Reply | None:
        if isinstance(c, d.Sleep):
            await self.sleep(c.seconds)
            return d.Woke(c.job)
        if isinstance(c, d.Probe):
            return d.Probed(c.job, tuple(name for name in self.params.action_servers
                                         if not self.clients[d.Action(name)].server_is_ready()))
        if isinstance(c, d.CallArm):
            return d.ArmDone(c.job, await arm(self, self.arm_client, c.attempts))
        return await self._goal(c)

    async def _goal(self, c: d.SendGoal) -> d.GoalDone | None:
        """Send the goal and wait for its result. None when the job ended meanwhile (the
        result belongs to a state already left); a rejected goal fails with the reason."""
        client = self.clients[c.action]
        handle = await client.send_goal_async(_goal_msg(c.goal))
        if not self.driver.current(c.job):
            if handle.accepted:
                client.cancel_goal_async(handle)
            return None
        if handle.accepted:
            self._active = (client, handle)
        response = await handle.get_result_async()
        if not self.driver.current(c.job):
            return None
        self._active = None
        result = response.result
        message = str(result.message) if handle.accepted else f"rejected: {result.message}"
        outcome = d.goal_outcome(c.action, accepted=handle.accepted, success=result.success,
                                 code=int(result.result), codes=OUTCOMES.get(c.action, {}))
        return d.GoalDone(c.job, outcome, message,
                          float(getattr(result, "lateral_error", math.nan)))

    def _cancel_goal(self) -> None:
        active, self._active = self._active, None
        if active is not None and active[1].status not in (
                GoalStatus.SUCCEEDED, GoalStatus.CANCELED, GoalStatus.ABORTED):
            active[0].cancel_goal_async(active[1])

    def state_changed(self, state: str) -> None:
        """The machine entered ``state`` (a hook for a launch watching the mission; one
        that overrides it calls this one too)."""
        self.get_logger().info(f"mission: {state}")
        self._scan_wanted = scans(state)
        self._scan_answered = None  # asked on each change: another node may have switched it
        self._ask_scanner()

    # -- messages out ----------------------------------------------------------------------
    def publish_state(self) -> None:
        self._publish_state(self.driver.snapshot(self.now().nanoseconds))

    def _publish_state(self, s: d.Snapshot) -> None:
        msg = interfaces.new(STATE, header=_header(self.now().to_msg()), phase=s.phase.value,
                             previous_phase=s.previous_phase.value, state=s.state,
                             sub_state=s.state.rsplit(".", 1)[-1],
                             robot_marker_id=s.robot_marker_id,
                             landing_sequence=list(s.landing_sequence),
                             pads_landed=list(s.pads_landed), target_pad_id=s.target_pad_id,
                             pads_skipped=list(s.pads_skipped), score=s.score,
                             stop_reason=s.stop_reason)
        msg.phase_start = Time(s.phase_start_ns).to_msg()
        if s.elapsed_ns is not None:
            msg.elapsed = Duration(s.elapsed_ns).to_msg()
        self.state_pub.publish(msg)

    def _publish_event(self, event: MissionEvent, state: str) -> None:
        self.event_pub.publish(interfaces.new(
            EVENT, header=_header(self.now().to_msg()), severity=event.severity.value,
            kind=event.kind.value, phase=phase_of(state).value, state=state,
            marker_id=event.marker_id, message=event.message,
            values=[interfaces.new("diagnostic_msgs/msg/KeyValue", key=k, value=v)
                    for k, v in event.values]))

    def _robot_msg(self, picture: object) -> Any:
        if not isinstance(picture, d.NoPicture):
            return picture
        msg = interfaces.new(ROBOT, marker_id=picture.marker_id, position_std=math.nan,
                             sightings=0)
        msg.header = _header(self.now().to_msg())
        msg.pose.position = _point(picture.x, picture.y, 0.0)
        msg.pose.orientation.w = 1.0
        return msg


def _goal_msg(goal: d.Goal) -> Any:
    if isinstance(goal, d.TakeoffGoal):
        return interfaces.new(TAKEOFF.Goal, altitude=goal.altitude)
    if isinstance(goal, d.LandGoal):
        return interfaces.new(LAND.Goal, disarm=goal.disarm, speed=goal.speed)
    if isinstance(goal, d.ExploreGoal):
        return interfaces.new(EXPLORE.Goal, altitude=goal.altitude,
                              stop_marker_ids=list(goal.stop_marker_ids),
                              time_budget=Duration.from_seconds(goal.time_budget_s).to_msg())
    if isinstance(goal, d.PrecisionLandGoal):
        msg = interfaces.new(PRECISION_LAND.Goal, pad_id=goal.pad,
                             search_radius=goal.search_radius)
        msg.pad_position = _point(*goal.position, 0.0)
    elif isinstance(goal, d.NavigateGoal):
        msg = interfaces.new(NAVIGATE.Goal, yaw=math.nan)
        msg.goal = _point(*goal.position)
    else:
        msg = interfaces.new(REACH.Goal, stop_at_target=True)
        msg.target.position = _point(*goal.position)
    return msg


def _point(x: float, y: float, z: float) -> Any:
    return interfaces.new("geometry_msgs/msg/Point", x=float(x), y=float(y), z=float(z))


def _header(stamp: Any) -> Any:
    return interfaces.new("std_msgs/msg/Header", stamp=stamp, frame_id="map")


__all__ = ["COMMAND_TOPIC", "EVENTS_TOPIC", "ROBOT_TOPIC", "STATE_TOPIC", "MissionNode"]
