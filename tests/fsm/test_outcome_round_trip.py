"""Each action's end, from its policy's outcome over the wire to the mission's decision.

A policy ends with an :class:`~flight_control.policy.Outcome`; its node puts a result code
and ``success`` on the wire (the navigator's ``NAVIGATE_CODES``, ``EXPLORE_CODES`` and
``TAKEOFF_CODES``, precision land's ``PRECISION_LAND_CODES``, the flight-control motion
actions' codes); the mission node reads the result back as an ``Outcome``
(:func:`fsm.mission_driver.goal_outcome` with :data:`fsm.mission_messages.OUTCOMES`) and the
driver turns it into the mission machine's input. :data:`ROUND_TRIP` writes the whole way
down once, row by row, for a reader to check against the ``RESULT_*`` constants of
``interfaces/quadmission_interfaces/action/*.action``; the tests walk each row through the
code, and fail when a policy can end with an outcome that has no code."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import pytest

import interfaces
from flight_control.behaviours import BEHAVIOUR_OUTCOMES
from flight_control.flight_actions import motion_actions
from flight_control.params import FlightControlParams
from flight_control.policy import Finish, Outcome
from fsm import mission_messages
from fsm.mission_driver import (
    Action,
    ArmDone,
    Probed,
    SendGoal,
    goal_outcome,
)
from interfaces import graph
from navigation.navigator_messages import EXPLORE_CODES, NAVIGATE_CODES, TAKEOFF_CODES
from navigation.navigator_policy import EXPLORE_OUTCOMES, NAVIGATE_OUTCOMES, SURVEY_OUTCOMES
from navigation.precision_land_node import PRECISION_LAND_CODES
from navigation.precision_land_policy import PRECISION_LAND_OUTCOMES
from runtime.parameters import load_parameters
from tests.fsm.test_mission_driver import FLYING, PARAMS, Rig, exploring, flying_pads, started

OC = Outcome
FAILED = OC.FAILED
#: Each row: the mission's action, how its policy ended, the result code on the wire (the
#: .action file's constant) and ``success``, the mission's reading, and the input the
#: driver then gives the mission machine.
ROUND_TRIP: list[tuple[Action, Outcome, str, bool, Outcome, str]] = [
    # navigation/navigate: Navigate.action
    (Action.NAVIGATE, OC.SUCCEEDED, "RESULT_OK", True, OC.SUCCEEDED, "arrived"),
    (Action.NAVIGATE, OC.NO_PATH, "RESULT_NO_PATH", False, OC.NO_PATH, "unreachable"),
    (Action.NAVIGATE, OC.FLIGHT_ERROR, "RESULT_FLIGHT_ERROR", False, FAILED, "action_failed"),
    (Action.NAVIGATE, OC.CANCELED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    # (navigate has no stop condition, so never STOPPED; its table reads it as a cancel)
    (Action.NAVIGATE, OC.STOPPED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    # navigation/explore: Explore.action
    (Action.EXPLORE, OC.MARKER_FOUND, "RESULT_MARKER_FOUND", True, OC.MARKER_FOUND,
     "robot_found"),
    (Action.EXPLORE, OC.COVERED, "RESULT_COVERED", True, OC.COVERED, "explore_ended"),
    (Action.EXPLORE, OC.TIME_BUDGET, "RESULT_TIME_BUDGET", False, OC.TIME_BUDGET,
     "explore_ended"),
    (Action.EXPLORE, OC.FLIGHT_ERROR, "RESULT_FLIGHT_ERROR", False, FAILED, "action_failed"),
    (Action.EXPLORE, OC.CANCELED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    # navigation/takeoff, the survey turns after the climb: Takeoff.action
    (Action.SURVEY_TAKEOFF, OC.SUCCEEDED, "RESULT_OK", True, OC.SUCCEEDED, "took_off"),
    (Action.SURVEY_TAKEOFF, OC.FLIGHT_ERROR, "RESULT_TIMEOUT", False, FAILED, "action_failed"),
    (Action.SURVEY_TAKEOFF, OC.CANCELED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    # navigation/precision_land: PrecisionLand.action
    (Action.PRECISION_LAND, OC.SUCCEEDED, "RESULT_LANDED", True, OC.SUCCEEDED, "landed"),
    (Action.PRECISION_LAND, OC.MARKER_NOT_FOUND, "RESULT_MARKER_NOT_FOUND", False,
     OC.MARKER_NOT_FOUND, "marker_not_found"),
    (Action.PRECISION_LAND, OC.MARKER_LOST, "RESULT_MARKER_LOST", False, OC.MARKER_LOST,
     "marker_not_found"),
    (Action.PRECISION_LAND, OC.FLIGHT_ERROR, "RESULT_FLIGHT_ERROR", False, FAILED,
     "action_failed"),
    (Action.PRECISION_LAND, OC.TIMEOUT, "RESULT_TIMEOUT", False, FAILED, "action_failed"),
    (Action.PRECISION_LAND, OC.CANCELED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    # flight_control/takeoff (from a sequence pad, or resumed in the air): Takeoff.action
    (Action.TAKEOFF, OC.SUCCEEDED, "RESULT_OK", True, OC.SUCCEEDED, "took_off"),
    (Action.TAKEOFF, OC.LOST_CONTROL, "RESULT_FCU_REJECTED", False, FAILED, "action_failed"),
    (Action.TAKEOFF, OC.FCU_REJECTED, "RESULT_FCU_REJECTED", False, FAILED, "action_failed"),
    (Action.TAKEOFF, OC.TIMEOUT, "RESULT_TIMEOUT", False, FAILED, "action_failed"),
    (Action.TAKEOFF, OC.CANCELED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    (Action.TAKEOFF, OC.PREEMPTED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    # flight_control/land (landing where the vehicle is): Land.action
    (Action.LAND, OC.SUCCEEDED, "RESULT_OK", True, OC.SUCCEEDED, "landed"),
    (Action.LAND, OC.LOST_CONTROL, "RESULT_FCU_REJECTED", False, FAILED, "action_failed"),
    (Action.LAND, OC.FCU_REJECTED, "RESULT_FCU_REJECTED", False, FAILED, "action_failed"),
    (Action.LAND, OC.TIMEOUT, "RESULT_TIMEOUT", False, FAILED, "action_failed"),
    (Action.LAND, OC.CANCELED, "RESULT_CANCELED", False, FAILED, "action_failed"),
    (Action.LAND, OC.PREEMPTED, "RESULT_CANCELED", False, FAILED, "action_failed"),
]

_FC = {a.name: a for a in motion_actions(SimpleNamespace(  # type: ignore[arg-type]
    params=load_parameters(FlightControlParams, "flight_control")))}
#: Per action: the outcomes its policy can end with (as the policy names them) and its
#: node's outcome -> code table (codes as the .action file's constant names, or values).
POLICIES: dict[Action, tuple[frozenset[Outcome], dict[Outcome, Any]]] = {
    Action.NAVIGATE: (NAVIGATE_OUTCOMES, NAVIGATE_CODES),
    Action.EXPLORE: (EXPLORE_OUTCOMES, EXPLORE_CODES),
    Action.SURVEY_TAKEOFF: (SURVEY_OUTCOMES, TAKEOFF_CODES),
    Action.PRECISION_LAND: (PRECISION_LAND_OUTCOMES, PRECISION_LAND_CODES),
    Action.TAKEOFF: (BEHAVIOUR_OUTCOMES, dict(_FC["takeoff"].codes)),
    Action.LAND: (BEHAVIOUR_OUTCOMES, dict(_FC["land"].codes)),
}
#: The driver's actions it sends no goal to (a take-off resumed in the air is flight
#: control's take-off, not a reach).
UNSENT = {Action.REACH}
#: The inputs the driver gives the mission machine when an action ends.
MACHINE_INPUTS = ("took_off", "robot_found", "explore_ended", "arrived", "unreachable",
                  "landed", "marker_not_found", "action_failed")


def _result_type(action: Action) -> Any:
    return mission_messages.ACTIONS[action].interface().Result


def _wire(action: Action, outcome: Outcome) -> tuple[int, bool]:
    """The result code and ``success`` the action's node sends when its policy ends with
    ``outcome``: the navigation nodes send :attr:`Finish.success`, the flight-control
    server ``outcome is SUCCEEDED``."""
    code = POLICIES[action][1][outcome]
    if isinstance(code, str):  # a flight-control motion action's constant name
        return int(getattr(_result_type(action), code)), outcome is Outcome.SUCCEEDED
    return int(code), Finish(outcome, "").success


def _read(action: Action, code: int, success: bool) -> Outcome:
    """The mission node's reading of an accepted goal's result."""
    return goal_outcome(action, accepted=True, success=success, code=code,
                        codes=mission_messages.OUTCOMES.get(action, {}))


def _running(action: Action) -> Rig:
    """The mission driver with a goal of ``action`` in hand."""
    if action is Action.SURVEY_TAKEOFF:  # from the start pad
        rig = started()
        rig.feed(Probed(rig.job.job, ()))
        rig.feed(ArmDone(rig.job.job, None))
        rig.feed(FLYING)
    elif action is Action.EXPLORE:
        rig = exploring()
    elif action is Action.NAVIGATE:  # to the first pad of the sequence
        rig = flying_pads()
    elif action in (Action.PRECISION_LAND, Action.TAKEOFF):  # on the pad, then up again
        rig = flying_pads()
        rig.done()
        if action is Action.TAKEOFF:
            rig.feed(replace(FLYING, landed=True))
            rig.done(lateral_error=0.04)
    else:  # LAND: the battery critical while exploring, land where it is
        rig = exploring()
        rig.feed(replace(FLYING, battery_warning=PARAMS.battery_critical_warning))
        rig.tick()
    assert isinstance(rig.job, SendGoal) and rig.job.action is action, rig.job
    return rig


def _decision(action: Action, outcome: Outcome) -> str:
    """The machine input the driver gives when a goal of ``action`` ends read as
    ``outcome`` (the machine's methods are replaced by a record of the call)."""
    rig = _running(action)
    called: list[str] = []
    for name in MACHINE_INPUTS:
        setattr(rig.driver.mission, name,
                lambda *_args, _name=name: called.append(_name) or True)
    rig.done(outcome, "why", lateral_error=0.02)
    if not called:  # a failure in the air waits for a cause it may be the consequence of
        rig.tick(PARAMS.failure_cause_wait_s)
    assert len(called) == 1, called
    return called[0]


@pytest.mark.parametrize(("action", "ended", "constant", "success", "read", "decided"),
                         ROUND_TRIP, ids=[f"{r[0].name}-{r[1].name}" for r in ROUND_TRIP])
def test_a_policys_end_crosses_the_wire_to_the_mission_as_the_table_says(
        action: Action, ended: Outcome, constant: str, success: bool, read: Outcome,
        decided: str) -> None:
    code, sent_success = _wire(action, ended)
    assert code == getattr(_result_type(action), constant), f"{ended.name} is not {constant}"
    assert sent_success is success
    assert _read(action, code, sent_success) is read
    assert _decision(action, read) == decided


def test_every_action_the_driver_sends_has_its_policy_here() -> None:
    assert set(POLICIES) == set(Action) - UNSENT


@pytest.mark.parametrize("action", list(POLICIES), ids=lambda a: a.name)
def test_every_outcome_a_policy_ends_with_has_a_code_and_a_row(action: Action) -> None:
    ends, codes = POLICIES[action]
    assert not ends - set(codes), f"{action.name}: no result code for {ends - set(codes)}"
    rows = {r[1] for r in ROUND_TRIP if r[0] is action}
    assert rows == set(codes), f"{action.name}: rows {rows} != the node's table {set(codes)}"


def test_every_code_the_mission_reads_apart_is_one_a_policy_sends() -> None:
    for action, codes in mission_messages.OUTCOMES.items():
        sent = {_wire(action, r[1])[0] for r in ROUND_TRIP if r[0] is action}
        assert set(codes) <= sent, f"{action.name}: read but never sent: {set(codes) - sent}"


def test_a_failed_climb_before_the_survey_reads_as_a_failure() -> None:
    """The navigator's take-off passes the flight-control take-off's failure on as is
    (its code, success false): the mission reads any such code as a failure."""
    result = graph.NAVIGATION_TAKEOFF.interface().Result
    failures = {c.name: int(c.value) for c in interfaces.describe(result)[0]
                if c.name.startswith("RESULT_") and c.name != "RESULT_OK"}
    assert failures
    for name, code in failures.items():
        assert _read(Action.SURVEY_TAKEOFF, code, False) is Outcome.FAILED, name
