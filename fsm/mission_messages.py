"""The mission node's messages: the driver's goals as action goals, its snapshots, events
and pictures as MissionState, MissionEvent and RobotFound, the operator's commands as
orders, and the result codes that are not a plain success or failure. Conversion only, no
node; not pure in ``tests/test_layers.py``'s sense (``PURE_MODULES``): its time stamps are
:mod:`runtime.clock` values, so importing it loads runtime/. :mod:`fsm.mission_node` sends
and receives them."""

from __future__ import annotations

import math
from typing import Any

import interfaces
from flight_control.policy import Outcome
from fsm import mission_driver as d
from fsm.mission_machine import MissionEvent
from fsm.mission_table import phase_of
from interfaces import graph
from runtime.clock import Duration, Time

QM = "quadmission_interfaces"
#: The action each of the driver's actions is, in the graph contract.
ACTIONS: dict[d.Action, graph.Action] = {
    d.Action.SURVEY_TAKEOFF: graph.NAVIGATION_TAKEOFF,
    d.Action.TAKEOFF: graph.TAKEOFF,
    d.Action.LAND: graph.LAND,
    d.Action.REACH: graph.REACH,
    d.Action.EXPLORE: graph.EXPLORE,
    d.Action.NAVIGATE: graph.NAVIGATE,
    d.Action.PRECISION_LAND: graph.PRECISION_LAND,
}
TAKEOFF = graph.TAKEOFF.interface()
LAND = graph.LAND.interface()
REACH = graph.REACH.interface()
EXPLORE = graph.EXPLORE.interface()
NAVIGATE = graph.NAVIGATE.interface()
PRECISION_LAND = graph.PRECISION_LAND.interface()
EXPLORE_RESULT: Any = EXPLORE.Result
NAVIGATE_RESULT: Any = NAVIGATE.Result
LAND_RESULT: Any = PRECISION_LAND.Result
COMMAND: Any = graph.MISSION_COMMAND.interface()
STATE: Any = graph.MISSION_STATE.interface()
EVENT: Any = graph.MISSION_EVENTS.interface()
HEALTH: Any = interfaces.get_message(f"{QM}/msg/ModuleHealth")
ROBOT = graph.MISSION_ROBOT.type

#: Result codes that are not a plain success or failure, per action.
OUTCOMES: dict[d.Action, dict[int, Outcome]] = {
    d.Action.EXPLORE: {EXPLORE_RESULT.RESULT_MARKER_FOUND: Outcome.MARKER_FOUND,
                       EXPLORE_RESULT.RESULT_COVERED: Outcome.COVERED,
                       EXPLORE_RESULT.RESULT_TIME_BUDGET: Outcome.TIME_BUDGET},
    d.Action.NAVIGATE: {NAVIGATE_RESULT.RESULT_NO_PATH: Outcome.NO_PATH},
    d.Action.PRECISION_LAND: {LAND_RESULT.RESULT_MARKER_NOT_FOUND: Outcome.MARKER_NOT_FOUND,
                              LAND_RESULT.RESULT_MARKER_LOST: Outcome.MARKER_LOST},
}
ORDERS = {getattr(COMMAND, f"COMMAND_{order.name}"): order for order in d.Order}


def command_input(msg: Any) -> d.Input:
    """A MissionCommand as the driver's input (an unknown command as such)."""
    order, seq = ORDERS.get(int(msg.command)), msg.sequence
    return d.UnknownCommand(int(msg.command)) if order is None else d.OperatorCommand(
        order, str(msg.reason), tuple(int(p) for p in seq.pad_ids),
        tuple(int(p) for p in seq.pad_points))


def goal_msg(goal: d.Goal) -> Any:
    """The action goal of one of the driver's goals."""
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
        msg.pad_position = interfaces.point(*goal.position, 0.0)
    elif isinstance(goal, d.NavigateGoal):
        msg = interfaces.new(NAVIGATE.Goal, yaw=math.nan)
        msg.goal = interfaces.point(*goal.position)
    else:
        msg = interfaces.new(REACH.Goal, stop_at_target=True)
        msg.target.position = interfaces.point(*goal.position)
    return msg


def state_msg(s: d.Snapshot, stamp: Any) -> Any:
    """The MissionState of a snapshot, stamped ``stamp``."""
    msg = interfaces.new(STATE, header=header(stamp), phase=s.phase.value,
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
    return msg


def event_msg(event: MissionEvent, state: str, stamp: Any) -> Any:
    """The MissionEvent of ``event``, in ``state``, stamped ``stamp``."""
    return interfaces.new(
        EVENT, header=header(stamp), severity=event.severity.value,
        kind=event.kind.value, phase=phase_of(state).value, state=state,
        marker_id=event.marker_id, message=event.message,
        values=[interfaces.new("diagnostic_msgs/msg/KeyValue", key=k, value=v)
                for k, v in event.values])


def robot_msg(picture: object, stamp: Any) -> Any:
    """A picture as it is sent: a RobotFound as received, or, for the driver's
    :class:`~fsm.mission_driver.NoPicture`, one with the robot's position and no image."""
    if not isinstance(picture, d.NoPicture):
        return picture
    msg = interfaces.new(ROBOT, marker_id=picture.marker_id, position_std=math.nan,
                         sightings=0)
    msg.header = header(stamp)
    msg.pose.position = interfaces.point(picture.x, picture.y, 0.0)
    msg.pose.orientation.w = 1.0
    return msg


def header(stamp: Any) -> Any:
    return interfaces.new("std_msgs/msg/Header", stamp=stamp, frame_id="map")
