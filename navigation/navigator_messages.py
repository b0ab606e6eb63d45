"""The navigator's messages: the flight-control goals its policies' commands become, the
planner's request, and the actions' result codes of the policies' outcomes. Pure
conversion, no runtime; :mod:`navigation.navigator_node` sends and receives them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import interfaces
from flight_control.policy import Outcome
from interfaces import graph
from navigation.navigator_policy import SendReach, SendTurn

NAVIGATE = graph.NAVIGATE.interface()
EXPLORE = graph.EXPLORE.interface()
TAKEOFF = graph.NAVIGATION_TAKEOFF.interface()
REACH = graph.REACH.interface()
TURN = graph.TURN.interface()
PLAN_PATH = graph.PLAN_PATH.interface()
_PLAN: Any = PLAN_PATH.Response
#: Plan failures that block a leg (the policy re-plans around them).
LEG_BLOCKED = (_PLAN.RESULT_GOAL_OCCUPIED, _PLAN.RESULT_NO_PATH)
_NAV: Any = NAVIGATE.Result
#: How navigate's policy ended -> the Navigate result code (the node sends
#: :attr:`~flight_control.policy.Finish.success` beside it, as for explore and takeoff).
NAVIGATE_CODES = {Outcome.SUCCEEDED: _NAV.RESULT_OK, Outcome.NO_PATH: _NAV.RESULT_NO_PATH,
                  Outcome.FLIGHT_ERROR: _NAV.RESULT_FLIGHT_ERROR,
                  Outcome.CANCELED: _NAV.RESULT_CANCELED, Outcome.STOPPED: _NAV.RESULT_CANCELED}
_EXP: Any = EXPLORE.Result
#: How explore's policy ended -> the Explore result code.
EXPLORE_CODES = {Outcome.MARKER_FOUND: _EXP.RESULT_MARKER_FOUND,
                 Outcome.COVERED: _EXP.RESULT_COVERED,
                 Outcome.TIME_BUDGET: _EXP.RESULT_TIME_BUDGET,
                 Outcome.CANCELED: _EXP.RESULT_CANCELED,
                 Outcome.FLIGHT_ERROR: _EXP.RESULT_FLIGHT_ERROR}
_TAKEOFF: Any = TAKEOFF.Result
#: How the survey after the climb ended -> the Takeoff result code.
TAKEOFF_CODES = {Outcome.SUCCEEDED: _TAKEOFF.RESULT_OK, Outcome.CANCELED: _TAKEOFF.RESULT_CANCELED,
                 Outcome.FLIGHT_ERROR: _TAKEOFF.RESULT_TIMEOUT}


def plan_request(start: np.ndarray, goal: np.ndarray) -> Any:
    """The PlanPath request from ``start`` to ``goal`` [m, map frame]."""
    return interfaces.new(PLAN_PATH.Request, start=interfaces.point(*start),
                          goal=interfaces.point(*goal))


def flight_goal(command: SendReach | SendTurn) -> Any:
    """The Reach or Turn goal of ``command``."""
    if isinstance(command, SendTurn):
        return interfaces.new(TURN.Goal, yaw=command.yaw, relative=command.relative)
    goal = interfaces.new(REACH.Goal, radius=command.radius, speed=command.speed,
                          stop_at_target=command.stop_at_target)
    goal.target.position = interfaces.point(*command.target)
    goal.target.orientation = interfaces.new("geometry_msgs/msg/Quaternion", x=0.0, y=0.0,
                                             z=math.sin(command.yaw / 2.0),
                                             w=math.cos(command.yaw / 2.0))
    return goal


__all__ = ["EXPLORE", "EXPLORE_CODES", "LEG_BLOCKED", "NAVIGATE", "NAVIGATE_CODES", "REACH",
           "TAKEOFF", "TAKEOFF_CODES", "TURN", "flight_goal", "plan_request"]
