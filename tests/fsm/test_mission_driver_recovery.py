"""Recovery, tick by tick (issue 39): a transient cause holds the mission in ``held``; clear
for the settle time, it resumes where it was (offboard taken back first when the FCU's
failsafe flew, the interrupted state's action restarted, its budget net of the hold); not
clear by the deadline, or no resume left, the permanent reaction; none allowed, today's
stop at once (the seed's rule)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from flight_control.policy import Outcome
from fsm.mission_driver import (
    Action,
    ArmDone,
    CallArm,
    CancelGoal,
    ExploreGoal,
    GoalDone,
    Health,
    NavigateGoal,
    OperatorCommand,
    Order,
    Position,
    Probed,
    PublishEvent,
    ReachGoal,
    SendGoal,
    TakeoffGoal,
    Tick,
    VehicleStatus,
)
from fsm.mission_machine import EventKind, MissionConfig, Severity
from fsm.mission_table import ERROR_POLICY, ErrorCause, Reaction
from tests.fsm.test_mission_driver import (
    CONFIG,
    FLYING,
    PARAMS,
    TOPICS,
    Rig,
    awaiting_sequence,
    exploring,
    flying_pads,
    of,
    started,
)

RESUMES = replace(CONFIG, max_resumes=2)
IN_OFFBOARD = replace(FLYING, offboard=True)
NO_POSITION = replace(IN_OFFBOARD, position_valid=False)
#: the FCU's offboard-loss failsafe holds (AUTO_LOITER), the setpoints reaching it again
FCU_HOLDS = replace(FLYING, offboard=False, failsafe=True)
SETTLE_S, DEADLINE_S = PARAMS.recovery_settle_s, PARAMS.recovery_deadline_s


def rig_exploring(config: MissionConfig = RESUMES) -> Rig:
    rig = exploring(Rig(config=config))
    rig.feed(IN_OFFBOARD)
    return rig


def lose_position(rig: Rig, after_s: float = 0.1) -> None:
    rig.feed(NO_POSITION, after_s)
    rig.tick(0.0)


def settle(rig: Rig, seconds: float, step_s: float = 0.1) -> None:
    """The watchdog now (it sees the cause clear), then every ``step_s`` for ``seconds``."""
    rig.tick(0.0)
    for _ in range(round(seconds / step_s)):
        rig.tick(step_s)


def hold_events(rig: Rig) -> list[dict[str, str]]:
    return [dict(e.values) for e in rig.events() if "reaction" in dict(e.values)]


def test_the_transient_causes_are_those_that_can_clear() -> None:
    assert {c for c, p in ERROR_POLICY.items() if p.transient} == {
        ErrorCause.LOCALISATION_LOST, ErrorCause.OFFBOARD_LOST, ErrorCause.MODULE_SILENT,
        ErrorCause.MODULE_ERROR}


def test_a_lost_position_holds_then_resumes_the_exploration_after_the_settle_time() -> None:
    rig = rig_exploring()
    rig.tick(30.0)  # explored 30 s
    lose_position(rig)
    assert rig.state == "held" and rig.driver.mission.stop is None
    assert CancelGoal() in rig.out  # the exploration canceled: the vehicle holds
    assert hold_events(rig)[-1] == {"cause": "localisation_lost", "reaction": "HOLD",
                                    "state": "mission.explore"}
    rig.tick(4.0)  # still lost: held on
    assert rig.state == "held"
    rig.feed(IN_OFFBOARD)  # the visual odometry is back
    settle(rig, SETTLE_S - 0.1)
    assert rig.state == "held"  # not yet clear for the settle time
    out = rig.tick(0.1)
    assert rig.state == "mission.explore"
    assert hold_events(rig)[-1]["reaction"] == "RESUME"
    # a new explore goal from where the vehicle is, its budget net of the 30.1 s explored
    # (the hold is not exploring)
    (goal,) = of(out, SendGoal)
    assert goal.action is Action.EXPLORE and isinstance(goal.goal, ExploreGoal)
    assert goal.goal.time_budget_s == pytest.approx(600.0 - 30.1, abs=1e-6)
    assert rig.driver.held_s == pytest.approx(4.0 + SETTLE_S, abs=1e-6)
    assert rig.driver.mission.resumes == 1


def test_a_cause_back_during_the_settle_time_starts_it_again() -> None:
    rig = rig_exploring()
    lose_position(rig)
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S - 0.5)
    lose_position(rig)  # again, before the settle time was up
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S - 0.1)
    assert rig.state == "held"
    rig.tick(0.1)
    assert rig.state == "mission.explore"


def test_not_clear_by_the_deadline_the_permanent_reaction_follows() -> None:
    rig = rig_exploring()
    lose_position(rig)
    rig.feed(NO_POSITION)
    rig.tick(DEADLINE_S - 0.1)
    rig.feed(NO_POSITION)
    assert rig.state == "held"
    rig.tick(0.1)
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert (stop.cause, stop.reaction, stop.state) == (
        ErrorCause.LOCALISATION_LOST, Reaction.HOLD, "mission.explore")
    assert "not clear after 30.0 s" in stop.detail


def test_too_many_resumes_and_the_next_cause_is_permanent() -> None:
    rig = rig_exploring(replace(CONFIG, max_resumes=1))
    lose_position(rig)
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S)
    assert rig.state == "mission.explore"
    lose_position(rig, 5.0)  # no resume left: the seed's stop at once
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert stop.cause is ErrorCause.LOCALISATION_LOST


@pytest.mark.parametrize("cause", ["position", "module_error", "module_silent", "link"])
def test_zero_resumes_is_todays_stop_at_once(cause: str) -> None:
    rig = rig_exploring(replace(CONFIG, max_resumes=0))
    if cause == "position":
        lose_position(rig)
    elif cause == "module_error":
        rig.feed(Health(TOPICS[0], False, True, "no position"))
        rig.feed(Tick(), 0.1)
    elif cause == "module_silent":
        rig.feed(Tick(), PARAMS.silence_timeout_s + 0.1)
    else:
        rig.feed(Tick(), PARAMS.status_timeout_s + 0.1)  # no /fcu/status: the link lost
    assert rig.state == "stopped" and "held" not in rig.states()


def test_a_lost_fcu_link_holds_and_the_resume_takes_offboard_back_first() -> None:
    """The link lost: no /fcu/status. Back, the FCU's offboard-loss failsafe still flies
    (its hold, or its land): once clear for the settle time, flight control's take-off
    asks PX4 for offboard and climbs where the vehicle is; then the exploration again."""
    rig = rig_exploring()
    rig.feed(Tick(), PARAMS.status_timeout_s - 0.1)
    assert rig.state == "mission.explore"
    rig.feed(Tick(), 0.2)  # 1.1 s without a status, in the air
    assert rig.state == "held"
    assert hold_events(rig)[-1]["cause"] == "offboard_lost"
    rig.feed(replace(FCU_HOLDS, offboard_signal_lost=True), 1.0)  # back; the FCU still waits
    rig.tick(0.0)
    rig.feed(FCU_HOLDS, 0.2)  # the setpoints reach it again
    settle(rig, SETTLE_S - 0.1)
    assert rig.state == "held"
    out = rig.tick(0.1)
    assert rig.state == "held"  # offboard first
    assert of(out, SendGoal) == [SendGoal(rig.job.job, Action.TAKEOFF, TakeoffGoal(1.5))]
    rig.feed(IN_OFFBOARD)
    out = rig.done(after_s=3.0)
    assert rig.state == "mission.explore"
    assert of(out, SendGoal)[0].action is Action.EXPLORE


def test_offboard_refused_waits_another_settle_time_then_the_deadline() -> None:
    rig = rig_exploring()
    rig.feed(Tick(), PARAMS.status_timeout_s + 0.1)
    rig.feed(FCU_HOLDS, 0.5)
    settle(rig, SETTLE_S)
    assert isinstance(rig.job, SendGoal) and rig.job.action is Action.TAKEOFF
    first = rig.job.job
    rig.done(Outcome.FCU_REJECTED, "DO_SET_MODE refused", after_s=0.5)
    assert rig.state == "held"
    settle(rig, SETTLE_S)
    assert rig.job.action is Action.TAKEOFF and rig.job.job != first  # asked again
    rig.done(Outcome.FCU_REJECTED, "DO_SET_MODE refused", after_s=0.5)
    settle(rig, DEADLINE_S)
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert stop.cause is ErrorCause.OFFBOARD_LOST


def test_a_failure_under_the_fcus_failsafe_with_no_cause_holds_and_resumes() -> None:
    """The FCU switched out of offboard and its failsafe flies (a short link loss): the
    explore fails, no cause comes in ``failure_cause_wait_s``: offboard_lost, held; the
    FCU back in offboard on its own, the exploration resumes."""
    rig = rig_exploring()
    rig.feed(FCU_HOLDS)
    rig.feed(GoalDone(rig.job.job, Outcome.FAILED, "explore: lost offboard control"), 0.5)
    settle(rig, PARAMS.failure_cause_wait_s + 0.1)
    assert rig.state == "held" and hold_events(rig)[-1]["cause"] == "offboard_lost"
    rig.feed(IN_OFFBOARD)  # the FCU's hold ended: back in offboard on its own
    settle(rig, SETTLE_S)
    assert rig.states()[-2:] == ["held", "mission.explore"]
    assert rig.job.action is Action.EXPLORE  # no take-off first: in offboard already


def test_a_reach_refused_for_a_lost_estimate_before_the_status_says_so_holds_and_resumes(
        ) -> None:
    """Flight control sees the FCU's position estimate go invalid before the mission's
    /fcu/status does, and refuses the explore's next reach (a wall-clock flight on a busy
    host: it used to stop the mission as a flight error). The failure waits for its cause:
    the status says the estimate is lost, a transient hold; back, the explore resumes."""
    rig = rig_exploring()
    rig.feed(GoalDone(rig.job.job, Outcome.FLIGHT_ERROR,
                      "reach rejected: no valid position estimate"), 0.5)
    assert rig.state == "mission.explore" and rig.driver.mission.stop is None
    lose_position(rig, PARAMS.failure_cause_wait_s / 2)  # the status, late
    assert rig.state == "held" and hold_events(rig)[-1]["cause"] == "localisation_lost"
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S + 0.1)
    assert rig.states()[-2:] == ["held", "mission.explore"]
    assert rig.job.action is Action.EXPLORE and rig.driver.mission.stop is None


def test_an_action_failure_with_no_cause_is_a_flight_error_after_the_wait() -> None:
    """No cause comes and the FCU's failsafe does not fly: the action itself failed,
    ``flight_error``, a permanent hold (the pilot decides), once the wait is over."""
    rig = rig_exploring()
    rig.feed(GoalDone(rig.job.job, Outcome.FLIGHT_ERROR, "no way on"), 0.5)
    rig.tick(PARAMS.failure_cause_wait_s - 0.1)
    assert rig.state == "mission.explore"
    rig.tick(0.2)
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert stop.cause is ErrorCause.FLIGHT_ERROR and stop.detail == "explore: no way on"


def test_the_fcus_failsafe_reported_during_the_wait_is_its_offboard_loss_not_a_flight_error(
        ) -> None:
    """Flight control saw the FCU leave offboard before /fcu/status said so: the failure
    came with no failsafe known; the failsafe reported during the wait, and no other
    cause, it is the FCU's offboard loss (held), not a flight error (a permanent stop)."""
    rig = rig_exploring()
    out = rig.feed(GoalDone(rig.job.job, Outcome.FLIGHT_ERROR,
                            "reach rejected: not in offboard control"), 0.5)
    (waiting,) = [e.event for e in of(out, PublishEvent)]
    assert waiting.severity is Severity.WARN and "waiting up to" in waiting.message
    rig.feed(FCU_HOLDS, PARAMS.failure_cause_wait_s / 2)
    settle(rig, PARAMS.failure_cause_wait_s)
    assert rig.state == "held" and hold_events(rig)[-1]["cause"] == "offboard_lost"
    assert rig.driver.mission.stop is None


@pytest.mark.parametrize("status", [replace(FLYING, landed=True),  # armed on the pad
                                    replace(FLYING, armed=False)],  # disarmed (its word)
                         ids=["armed_on_the_pad", "disarmed"])
def test_a_failure_on_the_ground_counts_at_once(status: VehicleStatus) -> None:
    """Not in the air and no failsafe: nothing the failure could be the consequence of
    can still come; the take-off's failure stops the mission at once, as before."""
    rig = started()
    rig.feed(Probed(rig.job.job, ()))
    rig.feed(ArmDone(rig.job.job, None))
    rig.feed(status)
    rig.feed(GoalDone(rig.job.job, Outcome.FLIGHT_ERROR, "no climb"))
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert stop.cause is ErrorCause.FLIGHT_ERROR and stop.detail == "takeoff: no climb"


def test_held_while_the_fcus_failsafe_lands_the_vehicle_ends_in_landed() -> None:
    rig = rig_exploring()
    lose_position(rig)
    rig.feed(replace(NO_POSITION, landed=True, failsafe=True), 4.0)  # the FCU's descent
    rig.tick(0.0)
    stop = rig.driver.mission.stop
    assert rig.state == "landed" and stop is not None
    assert stop.cause is ErrorCause.LOCALISATION_LOST and "landed" in stop.detail


def test_held_in_a_pads_landing_that_touched_down_takes_off_and_flies_that_pad_again(
        ) -> None:
    """The navigation process killed during pad 2's final descent (ros2, the default
    mission): held, then the landing touched down. It used to end in ``landed``; the
    resume takes off where the vehicle stands and flies pad 2 again, which is not scored
    as landed (the landing's end was not the precision landing's)."""
    rig = flying_pads(rig=Rig(config=RESUMES))
    rig.feed(IN_OFFBOARD)
    rig.done()  # above pad 2
    assert rig.state == "mission.pad.land"
    rig.feed(Health(TOPICS[0], True, False, ""))
    rig.feed(Tick(), PARAMS.silence_timeout_s + 0.1)  # /navigator/health silent
    assert rig.state == "held"
    rig.feed(replace(IN_OFFBOARD, landed=True, armed=False))  # the descent touched down
    rig.tick(0.0)
    assert rig.state == "held" and rig.driver.mission.stop is None
    assert any("flies pad 2 again" in e.message for e in rig.events())
    rig.tick(3.0)  # respawned: it reports again
    settle(rig, SETTLE_S)
    assert rig.state == "mission.pad.takeoff"
    assert rig.driver.mission.landed_pads == [] and rig.driver.mission.score == 0
    assert isinstance(rig.job, CallArm)  # disarmed on the pad: arm, then climb


def test_a_module_silent_on_a_pad_resumes_the_takeoff_when_it_reports_again() -> None:
    """A node's process dies between two pads and is respawned: silent, then healthy. On
    the ground in a take-off state the hold waits; the take-off then starts again."""
    rig = flying_pads(rig=Rig(config=RESUMES))
    rig.done()  # above pad 2
    rig.feed(replace(IN_OFFBOARD, landed=True, armed=False))
    rig.done()  # landed on pad 2
    assert rig.state == "mission.pad.takeoff"
    rig.feed(Health(TOPICS[0], True, False, ""))
    rig.feed(Tick(), PARAMS.silence_timeout_s + 0.1)  # /navigator/health silent
    assert rig.state == "held" and hold_events(rig)[-1]["cause"] == "module_silent"
    rig.tick(5.0)  # respawned: it reports again (with every module)
    settle(rig, SETTLE_S)
    assert rig.state == "mission.pad.takeoff"


def test_the_sequence_timeout_counts_the_time_waited_not_the_time_held() -> None:
    rig = awaiting_sequence(Rig(config=RESUMES))
    rig.feed(IN_OFFBOARD)
    rig.tick(100.0)
    lose_position(rig)
    rig.tick(20.0)
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S)
    assert rig.state == "mission.await_sequence"
    rig.tick(PARAMS.sequence_timeout_s - 100.0 - 0.2)
    assert rig.state == "mission.await_sequence"
    rig.tick(0.4)
    assert rig.driver.mission.stop is not None
    assert rig.driver.mission.stop.cause is ErrorCause.SEQUENCE_TIMEOUT


def test_a_navigation_leg_resumed_is_planned_again_to_the_same_pad() -> None:
    rig = flying_pads(rig=Rig(config=RESUMES))
    rig.feed(IN_OFFBOARD)
    lose_position(rig)
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S)
    assert rig.state == "mission.pad.navigate" and rig.driver.mission.target_pad == 2
    assert of(rig.out, SendGoal) == [SendGoal(rig.job.job, Action.NAVIGATE,
                                              NavigateGoal((3.0, 7.5, 1.5)))]


def test_a_precision_landing_held_in_its_descent_climbs_back_before_it_lands_again() -> None:
    """Flight control restarted while precision landing's descent was a few centimetres above
    the pad: the FCU kept offboard, but a goal from there is refused ("take off first").
    The resume climbs to cruise altitude where the vehicle is, then lands on the same pad."""
    rig = flying_pads(rig=Rig(config=RESUMES))
    rig.feed(IN_OFFBOARD)
    rig.done()
    assert rig.state == "mission.pad.land"
    lose_position(rig)
    assert rig.state == "held"
    rig.feed(IN_OFFBOARD)
    settle(rig, SETTLE_S)
    assert rig.state == "held"  # the climb first, though the FCU is still in offboard
    assert rig.job == SendGoal(rig.job.job, Action.TAKEOFF, TakeoffGoal(1.5))
    out = rig.done(after_s=2.0)
    assert rig.state == "mission.pad.land" and rig.driver.mission.target_pad == 2
    assert [g.action for g in of(out, SendGoal)] == [Action.PRECISION_LAND]


def test_a_battery_critical_while_held_lands_at_once() -> None:
    rig = rig_exploring()
    lose_position(rig)
    rig.feed(replace(NO_POSITION, battery_warning=2, battery_remaining=0.05))
    rig.tick(0.0)
    assert rig.state == "landing_now"


def test_while_held_the_operator_cannot_resume_but_can_abort() -> None:
    rig = rig_exploring()
    lose_position(rig)
    rig.feed(OperatorCommand(Order.RESUME))
    assert rig.state == "held"
    assert rig.events(EventKind.COMMAND_REJECTED)
    rig.feed(OperatorCommand(Order.ABORT, reason="pilot takes over"))
    assert rig.state == "stopped"
    assert rig.driver.mission.stop is not None
    assert rig.driver.mission.stop.cause is ErrorCause.OPERATOR_ABORT


def test_a_module_restarted_resumes_only_once_it_reports_ok() -> None:
    """A node's process respawned reports again before it has rebuilt its state (mapping
    without a fused cloud warns): reporting is not enough, the hold waits for OK, then the
    settle time."""
    rig = rig_exploring()
    rig.report_health()
    rig.watchdog(PARAMS.silence_timeout_s + 0.1)  # every module silent: the process died
    assert rig.state == "held" and hold_events(rig)[-1]["cause"] == "module_silent"
    for _ in range(round(3 * SETTLE_S / 0.1)):  # back, warning: not OK yet
        rig.t_ns += round(0.1e9)
        rig.report_health(ok=False, message="no depth cloud fused yet")
        rig.feed(rig.driver.status)
        rig.feed(Tick())
    assert rig.state == "held"
    settle(rig, SETTLE_S - 0.1)  # OK from now: not before the settle time
    assert rig.state == "held"
    settle(rig, 0.2)
    assert rig.state == "mission.explore" and isinstance(rig.job, SendGoal) \
        and rig.job.action is Action.EXPLORE


def test_held_on_a_silent_module_takes_the_setpoint_with_a_reach_to_where_it_is() -> None:
    """The navigator's process died with its reach to the end of a leg running at flight
    control: the mission's cancel reaches nobody, so the hold sends its own reach to where
    the vehicle is (flight control preempts the orphan); a lost position sends none (the
    reach would be refused) and the resume restarts the exploration."""
    rig = rig_exploring()
    rig.feed(Position((4.0, 5.0, 1.9)))
    rig.report_health()
    rig.watchdog(PARAMS.silence_timeout_s + 0.1)
    assert rig.state == "held"
    sent = [c for c in rig.out if isinstance(c, SendGoal)]
    assert [(c.action, c.goal) for c in sent] == [(Action.REACH, ReachGoal((4.0, 5.0, 1.9)))]
    assert rig.out.index(next(c for c in rig.out if isinstance(c, CancelGoal))) \
        < rig.out.index(sent[0])  # the explore canceled first
    settle(rig, SETTLE_S + 0.1)
    assert rig.state == "mission.explore" and rig.job.action is Action.EXPLORE

    lost = rig_exploring()
    lost.feed(Position((4.0, 5.0, 1.9)))
    lose_position(lost)
    assert lost.state == "held" and not any(isinstance(c, SendGoal) for c in lost.out)
