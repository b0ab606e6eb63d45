"""The mission node: :class:`~fsm.mission_machine.Mission` wired to the stack's interfaces.

It is the machine's :class:`~fsm.mission_machine.MissionDriver`: each request becomes a
goal of the layer below, each goal's result an input of the machine.

- actions: ``/navigation/takeoff`` from the start pad (it maps around after the climb),
  ``/flight_control/takeoff`` from the sequence's pads, ``/flight_control/land`` (with
  ``/flight_control/arm``), ``/navigation/explore``, ``navigate`` and ``precision_land``;
  a request always replaces the previous one, whose goal is canceled (cancel reaches
  the active child), and a result that comes back after its state was left is dropped;
- ``/mission/command`` (MissionCommand): START, PAUSE, RESUME, ABORT, RETURN_HOME and
  SEQUENCE, each answered on ``/mission/events`` (accepted or rejected, with the reason);
- ``/mission/state`` (MissionState: the nested state, the pad in hand, the score so far)
  on every change and at ``state_rate_hz``; ``/mission/events`` (MissionEvent);
- ``/mission/robot`` (RobotFound, the pictures): from the start of the exploration the
  node keeps the latest ``max_pictures`` ``/perception/robot_found`` of the target robot
  (the exploration stops past the robot, which may be out of view by then); in
  ``mission.report_robot`` it hovers ``report_hover_s`` (up to ``picture_timeout_s``
  more until a first one comes), then sends them to the operator (without any, the
  robot's ID and the vehicle's position, with a warning);
- alerts, checked at ``watchdog_rate_hz``: ``/fcu/status`` (position estimate invalid ->
  localisation lost; the battery warnings), each of ``health_topics`` (ERROR -> module
  error; no report for ``silence_timeout_s`` -> module silent), the sequence timeout.
  The error policy (:data:`~fsm.mission_table.ERROR_POLICY`) decides what follows.

Preflight asks every module: each action in ``action_servers`` must be ready and each
health topic must report OK within ``preflight_timeout_s``. ``timeline`` and ``events``
keep what happened, with the companion time, for reports.
"""

from __future__ import annotations

import math
from collections.abc import Coroutine
from dataclasses import dataclass
from functools import partial
from typing import Any

import interfaces
from flight_control.clients import arm, arm_client
from fsm.mission_machine import EventKind, Mission, MissionConfig, MissionEvent, Severity
from fsm.mission_table import ErrorCause, phase_of
from fsm.params import FIELD_SOURCE, MissionParams, PadsParams
from runtime import (
    ActionClient,
    Duration,
    Node,
    ParameterError,
    QoSProfile,
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
HEALTH_OK, HEALTH_ERROR = 0, 2  # ModuleHealth.LEVEL_*

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

ACTIONS: dict[str, tuple[Any, str]] = {
    "survey_takeoff": (TAKEOFF, "/navigation/takeoff"),  # climb, then turn round: mapping
    "takeoff": (TAKEOFF, "/flight_control/takeoff"),
    "land": (LAND, "/flight_control/land"),
    "reach": (REACH, "/flight_control/reach"),
    "explore": (EXPLORE, "/navigation/explore"),
    "navigate": (NAVIGATE, "/navigation/navigate"),
    "precision_land": (PRECISION_LAND, "/navigation/precision_land"),
}


@dataclass
class _Module:
    """The latest health report of one module."""

    level: int | None = None
    message: str = ""
    last_ns: int | None = None


class MissionNode(Node):
    """See the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("mission", **kwargs)
        self.params = self.declare_params(MissionParams)
        try:
            pads = self.declare_params(PadsParams)
        except ParameterError as exc:
            raise ParameterError(f"{exc}; {FIELD_SOURCE}") from None
        self.mission = Mission(MissionConfig(
            target_robot=self.params.target_robot, start_pad=pads.start_pad,
            pads=pads.positions(), search_radius_near=self.params.search_radius_near,
            search_radius_wide=self.params.search_radius_wide), self)
        self.timeline: list[tuple[float, str]] = [(self.now().seconds, self.mission.state)]
        self.events: list[tuple[float, MissionEvent]] = []
        self.pictures: list[Any] = []  # RobotFound of the target, while reporting
        self.status: Any = None  # the latest /fcu/status
        self.position: tuple[float, float, float] | None = None  # /fcu/odometry, map frame
        self.modules = {topic: _Module() for topic in self.params.health_topics}
        self._started_ns: int | None = None
        self._entered_ns = 0
        self._phase = self._previous_phase = phase_of(self.mission.state)
        self._token = 0  # bumped by every request and cancel: older results are dropped
        self._active: tuple[ActionClient, ClientGoalHandle] | None = None
        self._collecting = False

        self.arm_client = arm_client(self)
        self.clients = {name: ActionClient(self, kind, topic)
                        for name, (kind, topic) in ACTIONS.items()}
        self.state_pub = self.create_publisher(STATE, STATE_TOPIC, LATCHED)
        self.event_pub = self.create_publisher(EVENT, EVENTS_TOPIC, EVENTS_QOS)
        self.robot_pub = self.create_publisher(f"{QM}/msg/RobotFound", ROBOT_TOPIC, LATCHED)
        self.create_subscription(COMMAND, COMMAND_TOPIC, self._on_command, qos_profile_default)
        self.create_subscription(f"{QM}/msg/RobotFound", "/perception/robot_found",
                                 self._on_robot, qos_profile_default)
        self.create_subscription(f"{QM}/msg/FcuStatus", "/fcu/status", self._on_status,
                                 qos_profile_default)
        self.create_subscription("nav_msgs/msg/Odometry", "/fcu/odometry", self._on_odometry,
                                 qos_profile_sensor_data)
        for topic in self.params.health_topics:
            self.create_subscription(f"{QM}/msg/HealthReport", topic,
                                     partial(self._on_health, topic), qos_profile_default)
        self.create_timer(1.0 / self.params.state_rate_hz, self.publish_state)
        self.create_timer(1.0 / self.params.watchdog_rate_hz, self._watchdog)
        self.publish_state()

    # -- inputs --------------------------------------------------------------------------
    def _on_command(self, msg: Any) -> None:
        m, c = self.mission, int(msg.command)
        if c == COMMAND.COMMAND_START:
            if m.start().accepted:
                self._started_ns = self.now().nanoseconds
        elif c == COMMAND.COMMAND_PAUSE:
            m.pause()
        elif c == COMMAND.COMMAND_RESUME:
            m.resume()
        elif c == COMMAND.COMMAND_ABORT:
            m.abort(str(msg.reason))
        elif c == COMMAND.COMMAND_RETURN_HOME:
            m.return_home(str(msg.reason) or "operator's RETURN_HOME")
        elif c == COMMAND.COMMAND_SEQUENCE:
            seq = msg.sequence
            m.receive_sequence([int(p) for p in seq.pad_ids],
                               [int(p) for p in seq.pad_points])
        else:
            self.emit(MissionEvent(EventKind.COMMAND_REJECTED, f"unknown command {c}",
                                   Severity.WARN))
        self.publish_state()

    def _on_robot(self, msg: Any) -> None:
        """Pictures of the target robot, from the exploration (the one that stopped it is
        often the best: the vehicle stops past the robot) to the end of the report."""
        if self._collecting and int(msg.marker_id) == self.mission.config.target_robot:
            self.pictures.append(msg)
            del self.pictures[:-self.params.max_pictures]

    def _on_status(self, msg: Any) -> None:
        self.status = msg

    def _on_odometry(self, msg: Any) -> None:
        p = msg.pose.pose.position
        self.position = (float(p.x), float(p.y), float(p.z))

    def _on_health(self, topic: str, msg: Any) -> None:
        module = self.modules[topic]
        module.level = int(msg.level)
        module.message = "; ".join(str(h.message) for h in msg.modules if h.message)
        module.last_ns = self.now().nanoseconds

    # -- alerts --------------------------------------------------------------------------
    def _flying_phase(self) -> bool:
        state = self.mission.state
        return not (self.mission.finished or state in ("idle", "preflight"))

    def _watchdog(self) -> None:
        if self._flying_phase():
            for cause, detail in self.alerts():
                self.mission.error(cause, detail)
                if self.mission.finished:
                    break
        if self.mission.state == "mission.await_sequence":
            waited = (self.now().nanoseconds - self._entered_ns) / 1e9
            if waited > self.params.sequence_timeout_s:
                self.mission.error(ErrorCause.SEQUENCE_TIMEOUT,
                                   f"no landing sequence after {waited:.0f} s")

    def alerts(self) -> list[tuple[ErrorCause, str]]:
        """The error causes present now, the gravest first."""
        out: list[tuple[ErrorCause, str]] = []
        s, now = self.status, self.now().nanoseconds
        if s is not None and not s.position_valid:
            out.append((ErrorCause.LOCALISATION_LOST,
                        "the FCU's position estimate is not valid (visual odometry lost)"))
        for topic, module in self.modules.items():
            age = None if module.last_ns is None else (now - module.last_ns) / 1e9
            if age is None or age > self.params.silence_timeout_s:
                out.append((ErrorCause.MODULE_SILENT, f"{topic}: no report for "
                            f"{'ever' if age is None else f'{age:.1f} s'}"))
            elif module.level is not None and module.level >= HEALTH_ERROR:
                out.append((ErrorCause.MODULE_ERROR, f"{topic}: {module.message}"))
        if s is not None and s.battery_warning >= self.params.battery_critical_warning:
            out.append((ErrorCause.BATTERY_CRITICAL,
                        f"battery critical ({_percent(s.battery_remaining)})"))
        elif s is not None and s.battery_warning >= self.params.battery_low_warning:
            out.append((ErrorCause.BATTERY_LOW, f"battery low ({_percent(s.battery_remaining)})"))
        return out

    # -- the driver: requests of the machine ------------------------------------------------
    def check_health(self) -> None:
        self._run(self._preflight())

    async def _preflight(self) -> bool:
        waited, step = 0.0, 0.1
        while True:
            missing = self._not_ready()
            if not missing:
                return self.mission.preflight_result(True)
            if waited >= self.params.preflight_timeout_s:
                return self.mission.preflight_result(
                    False, f"after {self.params.preflight_timeout_s:g} s: " + "; ".join(missing))
            await self.sleep(step)
            waited += step

    def _not_ready(self) -> list[str]:
        """What keeps the mission from starting, one line per module."""
        out = [f"{name} server not available" for name in self.params.action_servers
               if not self.clients[name].server_is_ready()]
        for topic, module in self.modules.items():
            if module.level is None:
                out.append(f"{topic} did not answer")
            elif module.level != HEALTH_OK:
                out.append(f"{topic} not OK: {module.message}")
        if self.status is None:
            out.append("/fcu/status did not answer")
        elif not self.status.position_valid:
            out.append("no valid position estimate")
        return out

    def takeoff(self) -> None:
        self._run(self._takeoff())

    async def _takeoff(self) -> bool:
        s = self.status
        if s is not None and s.armed and not s.landed and self.position is not None:
            # resumed in the air: climb where we are (the take-off action needs the ground)
            x, y, _ = self.position
            result = await self._goal("reach", _reach_goal(x, y, self.params.cruise_altitude))
        else:
            if not (s is not None and s.armed):
                refused = await arm(self, self.arm_client, self.params.arm_attempts)
                if refused is not None:
                    return self.mission.action_failed(f"arm: {refused}")
            # from the start pad the navigator's take-off also maps all around; from a
            # sequence pad the flight-control take-off is enough
            first = self.mission.state == "mission.takeoff"
            result = await self._goal("survey_takeoff" if first else "takeoff", interfaces.new(
                TAKEOFF.Goal, altitude=self.params.cruise_altitude))
        if result is None:
            return False
        if result.success:
            return self.mission.took_off()
        return self.mission.action_failed(f"takeoff: {result.message}")

    def explore(self, target_robot: int) -> None:
        self._run(self._explore(target_robot))

    async def _explore(self, target_robot: int) -> bool:
        self.pictures.clear()
        self._collecting = True
        result = await self._goal("explore", interfaces.new(
            EXPLORE.Goal, altitude=self.params.cruise_altitude, stop_marker_ids=[target_robot],
            time_budget=Duration.from_seconds(self.params.explore_budget_s).to_msg()))
        if result is None:
            return False
        if result.result == EXPLORE_RESULT.RESULT_MARKER_FOUND:
            return self.mission.robot_found(target_robot)
        if result.result in (EXPLORE_RESULT.RESULT_COVERED, EXPLORE_RESULT.RESULT_TIME_BUDGET):
            return self.mission.explore_ended(f"robot {target_robot} not seen: {result.message}")
        return self.mission.action_failed(f"explore: {result.message}")

    def send_pictures(self) -> None:
        self._run(self._send_pictures())

    async def _send_pictures(self) -> bool:
        self._collecting = True
        await self.sleep(self.params.report_hover_s)
        waited = 0.0
        while not self.pictures and waited < self.params.picture_timeout_s:
            await self.sleep(0.1)
            waited += 0.1
        self._collecting = False
        if not self.pictures:  # the operator still needs to know which robot it is
            target = self.mission.config.target_robot
            self.emit(MissionEvent(
                EventKind.ERROR, f"no picture of robot {target} from perception after "
                f"{self.params.report_hover_s + waited:.0f} s: its ID and our position sent",
                Severity.WARN, marker_id=target))
            self.pictures.append(self._robot_without_picture(target))
        for msg in self.pictures:
            self.robot_pub.publish(msg)
        return self.mission.pictures_sent()

    def _robot_without_picture(self, marker_id: int) -> Any:
        x, y, _ = self.position if self.position is not None else (math.nan, math.nan, 0.0)
        msg = interfaces.new(f"{QM}/msg/RobotFound", marker_id=marker_id,
                             position_std=math.nan, sightings=0)
        msg.header = _header(self.now().to_msg())
        msg.pose.position = _point(x, y, 0.0)
        msg.pose.orientation.w = 1.0
        return msg

    def navigate(self, target: tuple[float, float]) -> None:
        self._run(self._navigate(target))

    async def _navigate(self, target: tuple[float, float]) -> bool:
        goal = interfaces.new(NAVIGATE.Goal, yaw=math.nan)
        goal.goal = _point(target[0], target[1], self.params.cruise_altitude)
        result = await self._goal("navigate", goal)
        if result is None:
            return False
        if result.success:
            return self.mission.arrived()
        if result.result == NAVIGATE_RESULT.RESULT_NO_PATH:
            return self.mission.unreachable(str(result.message))
        return self.mission.action_failed(f"navigate: {result.message}")

    def precision_land(self, pad: int, position: tuple[float, float],
                       search_radius: float) -> None:
        self._run(self._precision_land(pad, position, search_radius))

    async def _precision_land(self, pad: int, position: tuple[float, float],
                              search_radius: float) -> bool:
        goal = interfaces.new(PRECISION_LAND.Goal, pad_id=pad, search_radius=search_radius)
        goal.pad_position = _point(position[0], position[1], 0.0)
        result = await self._goal("precision_land", goal)
        if result is None:
            return False
        if result.success:
            return self.mission.landed(float(result.lateral_error))
        if result.result in (LAND_RESULT.RESULT_MARKER_NOT_FOUND, LAND_RESULT.RESULT_MARKER_LOST):
            return self.mission.marker_not_found(str(result.message))
        return self.mission.action_failed(f"precision land on pad {pad}: {result.message}")

    def land(self) -> None:
        self._run(self._land())

    async def _land(self) -> bool:
        result = await self._goal("land", interfaces.new(LAND.Goal, disarm=True,
                                                         speed=self.params.land_speed))
        if result is None:
            return False
        if result.success:
            return self.mission.landed()
        return self.mission.action_failed(f"land: {result.message}")

    def hold(self) -> None:
        """Nothing more to send: with its goal canceled the layer below holds the last
        setpoint (the seed's stop leaves the vehicle as it is for the pilot)."""

    def cancel(self) -> None:
        self._token += 1
        if self._active is not None:
            client, handle = self._active
            self._active = None
            if handle.status not in (GoalStatus.SUCCEEDED, GoalStatus.CANCELED,
                                     GoalStatus.ABORTED):
                client.cancel_goal_async(handle)

    def state_changed(self, state: str) -> None:
        now = self.now()
        self._entered_ns = now.nanoseconds
        self.timeline.append((now.seconds, state))
        if phase_of(state) != self._phase:
            self._previous_phase, self._phase = self._phase, phase_of(state)
        self.get_logger().info(f"mission: {state}")
        self.publish_state()

    def emit(self, event: MissionEvent) -> None:
        now = self.now()
        self.events.append((now.seconds, event))
        self.event_pub.publish(interfaces.new(
            EVENT, header=_header(now.to_msg()), severity=event.severity.value,
            kind=event.kind.value, phase=phase_of(self.mission.state).value,
            state=self.mission.state, marker_id=event.marker_id, message=event.message,
            values=[interfaces.new("diagnostic_msgs/msg/KeyValue", key=k, value=v)
                    for k, v in event.values]))

    # -- plumbing ------------------------------------------------------------------------
    def _run(self, coro: Coroutine[Any, Any, bool]) -> None:
        self._token += 1
        self.create_task(coro)

    async def _goal(self, name: str, goal: Any) -> Any | None:
        """Send ``goal`` to action ``name`` and wait for its result. None when the request
        was canceled or replaced meanwhile (the result belongs to a state already left);
        a rejected goal comes back as a failed result with the server's reason."""
        token = self._token
        client = self.clients[name]
        handle = await client.send_goal_async(goal)
        if token != self._token:
            if handle.accepted:
                client.cancel_goal_async(handle)
            return None
        if handle.accepted:
            self._active = (client, handle)
        response = await handle.get_result_async()
        if token != self._token:
            return None
        self._active = None
        result = response.result
        if not handle.accepted:
            result.success = False
            result.message = f"rejected: {result.message}"
        return result

    def publish_state(self) -> None:
        m, now = self.mission, self.now()
        msg = interfaces.new(STATE, header=_header(now.to_msg()), phase=self._phase.value,
                             previous_phase=self._previous_phase.value, state=m.state,
                             sub_state=m.state.rsplit(".", 1)[-1],
                             robot_marker_id=m.robot_marker or 0,
                             landing_sequence=list(m.sequence), pads_landed=m.landed_pads,
                             target_pad_id=m.target_pad,
                             pads_skipped=[s.pad for s in m.skipped], score=m.score,
                             stop_reason=m.stop.describe() if m.stop else "")
        msg.phase_start = _time_msg(self._entered_ns)
        if self._started_ns is not None:
            elapsed = now.nanoseconds - self._started_ns
            msg.elapsed = interfaces.new("builtin_interfaces/msg/Duration",
                                         sec=elapsed // 1_000_000_000,
                                         nanosec=elapsed % 1_000_000_000)
        self.state_pub.publish(msg)


def _percent(fraction: float) -> str:
    return "unknown" if math.isnan(fraction) else f"{100.0 * fraction:.0f} %"


def _point(x: float, y: float, z: float) -> Any:
    return interfaces.new("geometry_msgs/msg/Point", x=float(x), y=float(y), z=float(z))


def _reach_goal(x: float, y: float, z: float) -> Any:
    goal = interfaces.new(REACH.Goal, stop_at_target=True)
    goal.target.position = _point(x, y, z)
    return goal


def _header(stamp: Any) -> Any:
    return interfaces.new("std_msgs/msg/Header", stamp=stamp, frame_id="map")


def _time_msg(ns: int) -> Any:
    return interfaces.new("builtin_interfaces/msg/Time", sec=ns // 1_000_000_000,
                          nanosec=ns % 1_000_000_000)

__all__ = ["COMMAND_TOPIC", "EVENTS_TOPIC", "ROBOT_TOPIC", "STATE_TOPIC", "MissionNode"]
