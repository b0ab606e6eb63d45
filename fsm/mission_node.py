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
- inputs of the alerts, checked at ``watchdog_rate_hz``: ``/fcu/status`` and each
  module's health topic (``/<module>/health``, ``graph.HEALTH``: :data:`HEALTH_TOPICS`);
  preflight also needs every action of the ``action_servers`` parameter;
  ``/fcu/odometry`` gives the position (a take-off resumed in the air, the robot's
  position when no picture came).

``timeline`` and ``events`` keep what happened, with the companion time, for reports.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import fields
from functools import partial
from typing import Any

import interfaces
from flight_control.clients import arm, arm_client
from fsm import mission_driver as d
from fsm import mission_messages as m
from fsm.mission_machine import Mission, MissionConfig, MissionEvent
from fsm.mission_table import scans
from fsm.params import FIELD_SOURCE, MissionParams, PadsParams
from interfaces import graph
from runtime import (
    ActionClient,
    Node,
    ParameterError,
)
from runtime.action import ClientGoalHandle, GoalStatus

NODE_NAME = "mission"
SET_BOOL = graph.SCANNER_ENABLE.interface()
HEALTH_TOPICS = tuple(t.name for t in graph.HEALTH.values())
"""The HealthReport topics the mission watches: every module's (the graph contract's)."""


class MissionNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = p = self.declare_params(MissionParams)
        try:
            pads = self.declare_params(PadsParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        self.driver = d.Driver(MissionConfig(
            target_robot=p.target_robot, start_pad=pads.start_pad, pads=pads.positions(),
            search_radius_near=p.search_radius_near, search_radius_wide=p.search_radius_wide,
            max_resumes=p.max_resumes),
            d.DriverParams(health_topics=HEALTH_TOPICS,
                           **{f.name: getattr(p, f.name) for f in fields(d.DriverParams)
                              if f.name != "health_topics"}),
            self.now().nanoseconds)
        self.mission: Mission = self.driver.mission
        self.timeline: list[tuple[float, str]] = self.driver.timeline
        self.events: list[tuple[float, MissionEvent]] = self.driver.events
        self._active: tuple[ActionClient, ClientGoalHandle] | None = None

        self.arm_client = arm_client(self)
        self.scanner_enable = self.create_client(SET_BOOL, graph.SCANNER_ENABLE.name)
        self._scan_wanted = scans(self.mission.state)
        self._scan_answered: bool | None = None  # what the scanner last said it does
        self._scan_asked: Any = None  # the request in flight
        self.clients = {action: ActionClient(self, a.type, a.name)
                        for action, a in m.ACTIONS.items()}
        self.state_pub, self.event_pub, self.robot_pub = (
            self.create_publisher(t.type, t.name, t.qos)
            for t in (graph.MISSION_STATE, graph.MISSION_EVENTS, graph.MISSION_ROBOT))
        inputs: list[tuple[graph.Topic, Callable[[Any], None]]] = [
            (graph.MISSION_COMMAND, self._on_command),
            (graph.PERCEPTION_ROBOT_FOUND, self._on_robot), (graph.FCU_STATUS, self._on_status),
            (graph.FCU_ODOMETRY, self._on_odometry),
            *((t, partial(self._on_health, t.name)) for t in graph.HEALTH.values())]
        for topic, callback in inputs:
            self.create_subscription(topic.type, topic.name, callback, topic.subscriber_qos)
        self.create_timer(1.0 / p.state_rate_hz, self.publish_state)
        self.create_timer(1.0 / p.watchdog_rate_hz, self._watchdog)
        self.publish_state()

    # -- messages in -----------------------------------------------------------------------
    def _on_command(self, msg: Any) -> None:
        self._feed(m.command_input(msg))

    def _on_robot(self, msg: Any) -> None:
        self._feed(d.RobotSeen(int(msg.marker_id), msg))

    def _on_status(self, msg: Any) -> None:
        self._feed(d.VehicleStatus(bool(msg.position_valid), bool(msg.armed), bool(msg.landed),
                                   int(msg.battery_warning), float(msg.battery_remaining),
                                   bool(msg.failsafe), bool(msg.offboard),
                                   bool(msg.offboard_signal_lost)))

    def _on_odometry(self, msg: Any) -> None:
        p = msg.pose.pose.position
        self._feed(d.Position((float(p.x), float(p.y), float(p.z))))

    def _on_health(self, topic: str, msg: Any) -> None:
        level = int(msg.level)
        self._feed(d.Health(topic, level == m.HEALTH.LEVEL_OK, level >= m.HEALTH.LEVEL_ERROR,
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
                    self.robot_pub.publish(m.robot_msg(picture, self.now().to_msg()))
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
        handle = await client.send_goal_async(m.goal_msg(c.goal))
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
                                 code=int(result.result), codes=m.OUTCOMES.get(c.action, {}))
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
        self.state_pub.publish(m.state_msg(s, self.now().to_msg()))

    def _publish_event(self, event: MissionEvent, state: str) -> None:
        self.event_pub.publish(m.event_msg(event, state, self.now().to_msg()))


__all__ = ["HEALTH_TOPICS", "NODE_NAME", "MissionNode"]
