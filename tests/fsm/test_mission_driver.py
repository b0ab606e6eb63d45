"""The mission driver tick by tick, without the runtime: each input and the commands it
answers with, through the contest (preflight, take-off, exploration, the robot's pictures,
the sequence, every pad), the timeouts (preflight, explore budget, pictures, operator
silence), an action failing and the error policy's reactions, the operator's commands
mid-mission, and pads skipped with their reason."""

from __future__ import annotations

import ast
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from flight_control.policy import Outcome
from fsm import mission_driver
from fsm.mission_driver import (
    JOBS,
    PICTURE_POLL_S,
    PROBE_PERIOD_S,
    Action,
    ArmDone,
    CallArm,
    CancelGoal,
    Command,
    Driver,
    DriverParams,
    ExploreGoal,
    GoalDone,
    Health,
    Input,
    LandGoal,
    NavigateGoal,
    NoPicture,
    OperatorCommand,
    Order,
    Position,
    PrecisionLandGoal,
    Probe,
    Probed,
    PublishEvent,
    PublishState,
    RobotSeen,
    SendGoal,
    SendPictures,
    Sleep,
    StateChanged,
    TakeoffGoal,
    Tick,
    UnknownCommand,
    VehicleStatus,
    Woke,
)
from fsm.mission_machine import EventKind, MissionConfig, Severity
from fsm.mission_table import ErrorCause, Phase, Reaction

TOPICS = ("/flight_control/health", "/navigator/health")
PARAMS = DriverParams(
    cruise_altitude=1.5, explore_altitude=1.9, explore_budget_s=600.0, health_topics=TOPICS,
    preflight_timeout_s=0.5, silence_timeout_s=3.0, sequence_timeout_s=120.0,
    report_hover_s=1.0, picture_timeout_s=0.5, max_pictures=3, battery_low_warning=1,
    battery_critical_warning=2, land_speed=0.4, arm_attempts=5, failure_cause_wait_s=1.5,
    status_timeout_s=1.0, recovery_settle_s=2.0, recovery_deadline_s=30.0)
PADS = {1: (1.5, 1.5), 2: (3.0, 7.5), 3: (7.0, 10.5)}
CONFIG = MissionConfig(target_robot=19, start_pad=1, pads=PADS, search_radius_near=0.5,
                       search_radius_wide=2.0)
ON_GROUND = VehicleStatus(position_valid=True, armed=False, landed=True, battery_warning=0,
                          battery_remaining=0.9)
FLYING = replace(ON_GROUND, armed=True, landed=False)


class Rig:
    """The driver and a clock; remembers the last step's commands and the job in hand."""

    def __init__(self, params: DriverParams = PARAMS, start_ns: int = 0,
                 config: MissionConfig = CONFIG) -> None:
        self.t_ns = start_ns
        self.driver = Driver(config, params, start_ns)
        self.out: list[Command] = []
        self.job: Any = None  # the latest job command

    @property
    def state(self) -> str:
        return self.driver.mission.state

    def feed(self, event: Input, after_s: float = 0.0) -> list[Command]:
        self.t_ns += round(after_s * 1e9)
        self.out = self.driver.step(event, self.t_ns)
        jobs = [c for c in self.out if isinstance(c, JOBS)]
        assert len(jobs) <= 1, f"one job at a time, got {jobs}"
        if jobs:
            self.job = jobs[0]
        return self.out

    def done(self, outcome: Outcome = Outcome.SUCCEEDED, message: str = "",
             lateral_error: float = math.nan, after_s: float = 1.0) -> list[Command]:
        """The goal in hand ends ``after_s`` later, the modules and the FCU having kept
        reporting meanwhile (the link up)."""
        assert isinstance(self.job, SendGoal)
        self.t_ns += round(after_s * 1e9)
        self.report_health()
        if self.driver.status is not None:
            self.feed(self.driver.status)
        return self.feed(GoalDone(self.job.job, outcome, message, lateral_error))

    def failed(self, message: str) -> list[Command]:
        """The goal in hand fails in the air, and no cause comes while the driver waits
        for one (``failure_cause_wait_s``): the commands at the end of the wait."""
        self.done(Outcome.FAILED, message)
        return self.tick(self.driver.params.failure_cause_wait_s)

    def woke(self) -> list[Command]:
        assert isinstance(self.job, Sleep)
        return self.feed(Woke(self.job.job), self.job.seconds)

    def report_health(self, ok: bool = True, error: bool = False, message: str = "") -> None:
        for topic in TOPICS:
            self.feed(Health(topic, ok, error, message))

    def tick(self, after_s: float = 0.1) -> list[Command]:
        """The watchdog, ``after_s`` later, every module having just reported OK and the
        FCU its latest status again (the link up)."""
        self.t_ns += round(after_s * 1e9)
        self.report_health()
        if self.driver.status is not None:
            self.feed(self.driver.status)
        return self.feed(Tick())

    def watchdog(self, after_s: float) -> list[Command]:
        """The watchdog alone, ``after_s`` later, the FCU's status just refreshed (the
        link up) but no module's health."""
        self.t_ns += round(after_s * 1e9)
        if self.driver.status is not None:
            self.feed(self.driver.status)
        return self.feed(Tick())

    def events(self, kind: EventKind | None = None) -> list[Any]:
        return [e for _, e in self.driver.events if kind is None or e.kind is kind]

    def states(self) -> list[str]:
        return [s for _, s in self.driver.timeline]


def of(commands: list[Command], kind: type) -> list[Any]:
    return [c for c in commands if isinstance(c, kind)]


def started(rig: Rig | None = None) -> Rig:
    """Every module healthy, the vehicle on the start pad, START sent."""
    rig = rig or Rig()
    rig.report_health()
    rig.feed(ON_GROUND)
    rig.feed(Position((1.5, 1.5, 0.0)))
    rig.feed(OperatorCommand(Order.START))
    return rig


def exploring(rig: Rig | None = None) -> Rig:
    rig = started(rig)
    rig.feed(Probed(rig.job.job, ()))
    rig.feed(ArmDone(rig.job.job, None))
    rig.feed(FLYING)
    rig.done()
    assert rig.state == "mission.explore"
    return rig


def awaiting_sequence(rig: Rig | None = None) -> Rig:
    rig = exploring(rig)
    rig.feed(RobotSeen(19, "picture"))
    rig.done(Outcome.MARKER_FOUND)
    rig.woke()
    assert rig.state == "mission.await_sequence"
    return rig


def flying_pads(pads: tuple[int, ...] = (2, 3), points: tuple[int, ...] = (10, 20),
                rig: Rig | None = None) -> Rig:
    rig = awaiting_sequence(rig)
    rig.feed(OperatorCommand(Order.SEQUENCE, pads=pads, points=points), 5.0)
    assert rig.state == "mission.pad.navigate"
    return rig


# -- the contest ---------------------------------------------------------------------------
def test_the_contest_tick_by_tick_from_start_to_the_last_pad() -> None:
    rig = started()
    # START: accepted, the state changes and is published, the modules are probed
    assert rig.state == "preflight"
    assert [type(c) for c in rig.out] == [PublishEvent, StateChanged, PublishState,
                                          PublishEvent, Probe, PublishState]
    assert rig.out[0].event.kind is EventKind.COMMAND_ACCEPTED
    assert rig.out[1] == StateChanged("preflight")
    assert rig.out[2].snapshot.state == "preflight"
    # every server ready: take off, arming first (the vehicle is disarmed on the ground)
    out = rig.feed(Probed(rig.job.job, ()), 0.1)
    assert rig.state == "mission.takeoff"
    assert of(out, CallArm) == [CallArm(rig.job.job, 5)]
    arm_job = rig.job.job
    # armed: the same job goes on with the survey take-off (from the start pad)
    out = rig.feed(ArmDone(arm_job, None), 1.0)
    assert of(out, SendGoal) == [SendGoal(arm_job, Action.SURVEY_TAKEOFF, TakeoffGoal(1.5))]
    rig.feed(FLYING)
    rig.feed(Position((1.5, 1.5, 1.5)))
    # took off: explore until the target robot is seen, at the search altitude
    out = rig.done(after_s=20.0)
    assert rig.state == "mission.explore"
    assert of(out, SendGoal) == [SendGoal(rig.job.job, Action.EXPLORE,
                                          ExploreGoal(1.9, (19,), 600.0))]
    assert rig.job.job != arm_job
    # the target's pictures are kept from the start of the exploration, others ignored
    rig.feed(RobotSeen(19, "first"))
    rig.feed(RobotSeen(12, "another robot"))
    out = rig.done(Outcome.MARKER_FOUND, after_s=60.0)
    assert rig.state == "mission.report_robot"
    assert rig.events(EventKind.ROBOT_FOUND)[0].marker_id == 19
    assert of(out, Sleep) == [Sleep(1.0, job=rig.job.job)]  # hover, collecting
    rig.feed(RobotSeen(19, "second"))
    out = rig.woke()
    assert of(out, SendPictures)[0].pictures == ("first", "second")
    assert rig.state == "mission.await_sequence"
    # the operator's sequence: fly pad to pad
    out = rig.feed(OperatorCommand(Order.SEQUENCE, pads=(2, 3), points=(10, 20)), 5.0)
    assert rig.state == "mission.pad.navigate"
    assert of(out, SendGoal) == [SendGoal(rig.job.job, Action.NAVIGATE,
                                          NavigateGoal((3.0, 7.5, 1.5)))]
    out = rig.done(after_s=10.0)
    assert rig.state == "mission.pad.land"
    assert of(out, SendGoal)[0] == SendGoal(rig.job.job, Action.PRECISION_LAND,
                                            PrecisionLandGoal(2, (3.0, 7.5), 0.5))
    rig.feed(replace(FLYING, landed=True))  # on the pad, still armed
    out = rig.done(lateral_error=0.04, after_s=15.0)
    assert rig.state == "mission.pad.takeoff"
    landed = rig.events(EventKind.LANDED)[0]
    assert landed.marker_id == 2 and dict(landed.values) == {"lateral_error_m": "0.040"}
    # armed already: no arm call, the flight-control take-off (not the survey's)
    assert [type(c) for c in out if isinstance(c, JOBS)] == [SendGoal]
    assert of(out, SendGoal)[0].action is Action.TAKEOFF
    rig.feed(FLYING)
    rig.done()
    assert of(rig.out, SendGoal)[0].goal == NavigateGoal((7.0, 10.5, 1.5))
    rig.done()
    assert of(rig.out, SendGoal)[0].goal == PrecisionLandGoal(3, (7.0, 10.5), 0.5)
    out = rig.done(lateral_error=0.1)
    assert rig.state == "completed"
    assert not of(out, JOBS)
    m = rig.driver.mission
    assert m.landed_pads == [2, 3] and m.score == 30 and m.stop is None
    assert rig.events(EventKind.COMPLETED)
    assert rig.states() == [
        "idle", "preflight", "mission.takeoff", "mission.explore", "mission.report_robot",
        "mission.await_sequence", "mission.pad.navigate", "mission.pad.land",
        "mission.pad.takeoff", "mission.pad.navigate", "mission.pad.land", "completed"]


def test_the_timeline_and_events_carry_the_time_of_the_input() -> None:
    rig = Rig(start_ns=2_000_000_000)
    assert rig.driver.timeline == [(2.0, "idle")]
    rig.report_health()
    rig.feed(ON_GROUND)
    rig.feed(OperatorCommand(Order.START), after_s=1.5)
    assert rig.driver.timeline[-1] == (3.5, "preflight")
    assert rig.driver.events[0][0] == 3.5


def test_each_event_is_published_with_the_state_it_happened_in() -> None:
    rig = flying_pads()
    out = rig.failed("blocked")
    published = of(out, PublishEvent)
    error = next(p for p in published if p.event.kind is EventKind.ERROR)
    assert error.state == "mission.pad.navigate"
    assert published[-1].state == "stopped"  # the phase change, in the new state


def test_the_state_snapshot_follows_the_mission() -> None:
    rig = Rig(start_ns=1_000_000_000)
    s = rig.driver.snapshot(rig.t_ns)
    assert (s.state, s.phase, s.previous_phase) == ("idle", Phase.IDLE, Phase.IDLE)
    assert s.stop_reason == "" and s.pads_landed == () and s.score == 0
    assert s.elapsed_ns is None and s.phase_start_ns == 0 and s.robot_marker_id == 0
    rig = flying_pads()
    started_ns = next(t for t, state in rig.driver.timeline if state == "preflight")
    rig.done(after_s=3.0)  # above pad 2
    s = rig.driver.snapshot(rig.t_ns + 500_000_000)
    assert s.state == "mission.pad.land" and s.target_pad_id == 2
    assert (s.phase, s.previous_phase) == (Phase.LANDING_SEQUENCE, Phase.AWAIT_SEQUENCE)
    assert s.phase_start_ns == rig.t_ns
    assert s.elapsed_ns == rig.t_ns + 500_000_000 - round(started_ns * 1e9)
    assert s.robot_marker_id == 19 and s.landing_sequence == (2, 3)
    rig.feed(replace(FLYING, landed=True))
    rig.done(lateral_error=0.0)
    s = rig.driver.snapshot(rig.t_ns)
    assert s.pads_landed == (2,) and s.score == 10 and s.target_pad_id == 0
    assert (s.phase, s.previous_phase) == (Phase.LANDING_SEQUENCE, Phase.AWAIT_SEQUENCE)
    rig.feed(OperatorCommand(Order.ABORT, reason="wind"))
    s = rig.driver.snapshot(rig.t_ns)
    assert s.stop_reason.startswith("operator_abort in mission.pad.takeoff: wind")
    assert s.pads_skipped == ()


def test_the_state_published_on_a_change_is_the_state_entered() -> None:
    rig = flying_pads()
    out = rig.done()
    (changed,) = of(out, StateChanged)
    (snapshot,) = [c.snapshot for c in of(out, PublishState)]
    assert changed.state == snapshot.state == "mission.pad.land"
    assert snapshot.phase_start_ns == rig.t_ns


# -- preflight -----------------------------------------------------------------------------
def test_preflight_asks_again_until_every_module_is_ready() -> None:
    rig = Rig()
    rig.feed(ON_GROUND)
    rig.feed(OperatorCommand(Order.START))
    probe = rig.job
    out = rig.feed(Probed(probe.job, ("navigate",)))
    assert of(out, Sleep) == [Sleep(PROBE_PERIOD_S, job=probe.job)]
    out = rig.woke()
    assert of(out, Probe) == [Probe(probe.job)]  # the same job, asked again
    rig.report_health()
    rig.feed(Probed(probe.job, ()))
    assert rig.state == "mission.takeoff"


def test_preflight_gives_up_at_its_timeout_naming_every_module_not_ready() -> None:
    rig = Rig()
    rig.feed(Health(TOPICS[1], False, True, "no map"))
    rig.feed(OperatorCommand(Order.START))
    sleeps = 0
    while rig.state == "preflight":
        rig.feed(Probed(rig.job.job, ("navigate", "explore")))
        if isinstance(rig.job, Sleep) and rig.state == "preflight":
            sleeps += 1
            rig.woke()
    # probed at 0, 0.1 ... 0.5 s: the probe at the timeout is the last
    assert sleeps == round(PARAMS.preflight_timeout_s / PROBE_PERIOD_S)
    assert rig.state == "stopped"
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.PREFLIGHT_FAILED
    assert stop.detail == ("after 0.5 s: navigate server not available; explore server not "
                           "available; /flight_control/health did not answer; "
                           "/navigator/health not OK: no map; /fcu/status did not answer")


def test_preflight_needs_a_valid_position_estimate() -> None:
    rig = Rig(replace(PARAMS, preflight_timeout_s=0.0))
    rig.report_health()
    rig.feed(replace(ON_GROUND, position_valid=False))
    rig.feed(OperatorCommand(Order.START))
    rig.feed(Probed(rig.job.job, ()))
    stop = rig.driver.mission.stop
    assert stop is not None and stop.detail == "after 0 s: no valid position estimate"


# -- take-off ------------------------------------------------------------------------------
def test_an_arm_refusal_fails_the_takeoff_and_holds() -> None:
    rig = started()
    rig.feed(Probed(rig.job.job, ()))
    out = rig.feed(ArmDone(rig.job.job, "pre-arm checks failed"))
    assert not of(out, SendGoal)
    assert rig.state == "stopped"
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.FLIGHT_ERROR
    assert stop.reaction is Reaction.HOLD and stop.detail == "arm: pre-arm checks failed"


def test_a_takeoff_resumed_in_the_air_climbs_where_the_vehicle_is() -> None:
    rig = started()
    rig.feed(Probed(rig.job.job, ()))
    rig.feed(ArmDone(rig.job.job, None))
    rig.feed(FLYING)
    rig.feed(Position((1.4, 1.6, 0.8)))
    rig.feed(OperatorCommand(Order.PAUSE))  # halfway up
    out = rig.feed(OperatorCommand(Order.RESUME))
    assert rig.state == "mission.takeoff"
    # flight control's take-off (not the navigator's survey, which needs the ground): in
    # the air it climbs where the vehicle is, and takes offboard back if the FCU left it
    assert of(out, SendGoal) == [SendGoal(rig.job.job, Action.TAKEOFF, TakeoffGoal(1.5))]
    rig.done()
    assert rig.state == "mission.explore"


@pytest.mark.parametrize(("status", "position", "first"), [
    (FLYING, None, SendGoal),  # no position yet: the take-off action
    (replace(FLYING, landed=True), (1.0, 1.0, 0.0), SendGoal),  # armed on the ground
    (replace(FLYING, armed=False), (1.0, 1.0, 0.0), CallArm),  # in the air, disarmed?
])
def test_a_takeoff_arms_unless_armed_and_uses_the_takeoff_action_unless_flying(
        status: VehicleStatus, position: tuple[float, float, float] | None,
        first: type) -> None:
    rig = Rig(replace(PARAMS, health_topics=()))
    rig.feed(status)
    if position is not None:
        rig.feed(Position(position))
    rig.feed(OperatorCommand(Order.START))
    rig.feed(Probed(rig.job.job, ()))
    assert isinstance(rig.job, first)
    if first is SendGoal:
        assert rig.job.goal == TakeoffGoal(1.5)


def test_a_failed_takeoff_holds_with_the_reason() -> None:
    rig = started()
    rig.feed(Probed(rig.job.job, ()))
    rig.feed(ArmDone(rig.job.job, None))
    rig.done(Outcome.FAILED, "offboard refused")
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert stop.detail == "takeoff: offboard refused"


# -- exploration and the robot's pictures --------------------------------------------------
@pytest.mark.parametrize("ended", [Outcome.TIME_BUDGET, Outcome.COVERED])
def test_the_explore_budget_running_out_returns_home_and_lands(ended: Outcome) -> None:
    """The exploration ending without the robot, out of time or with the area covered."""
    rig = exploring()
    out = rig.done(ended, "time budget used up", after_s=600.0)
    assert rig.state == "returning.navigate"
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.ROBOT_NOT_FOUND
    assert stop.reaction is Reaction.RETURN_AND_LAND
    assert stop.detail == "robot 19 not seen: time budget used up"
    assert of(out, SendGoal)[0].goal == NavigateGoal((1.5, 1.5, 1.5))  # the start pad
    out = rig.done()
    assert of(out, SendGoal)[0].goal == PrecisionLandGoal(1, (1.5, 1.5), 2.0)  # wide search
    rig.done(lateral_error=0.1)
    assert rig.state == "landed"  # on the error: not completed


def test_an_explore_failure_holds() -> None:
    rig = exploring()
    rig.failed("no way on")
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None and stop.detail == "explore: no way on"


FAILSAFE = replace(FLYING, failsafe=True)


def test_a_failure_under_the_fcus_failsafe_waits_for_its_cause() -> None:
    """The FCU's battery failsafe switches it to AUTO_LAND at once; the explore's next
    reach is refused before the battery's warning (1 Hz) reaches the mission. The refusal
    is the failsafe's consequence: the battery decides (LAND_NOW), not a flight error."""
    rig = exploring()
    rig.feed(FAILSAFE)
    rig.done(Outcome.FAILED, "reach rejected: not in offboard control (FCU nav_state 18)")
    assert rig.state == "mission.explore" and rig.driver.mission.stop is None  # waiting
    rig.tick(0.5)
    assert rig.state == "mission.explore"
    rig.feed(replace(FAILSAFE, battery_warning=2, battery_remaining=0.05), 0.4)
    rig.tick(0.1)
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.BATTERY_CRITICAL
    assert stop.reaction is Reaction.LAND_NOW and rig.state == "landing_now"
    rig.tick(2.0)  # past the wait: the failure no longer counts
    assert rig.driver.mission.stop is stop


def test_a_failure_under_the_failsafe_with_a_known_cause_acts_on_the_cause_at_once() -> None:
    rig = exploring()
    rig.feed(replace(FAILSAFE, battery_warning=2, battery_remaining=0.05))
    rig.done(Outcome.FAILED, "reach rejected: not in offboard control (FCU nav_state 18)")
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.BATTERY_CRITICAL
    assert rig.state == "landing_now"


def test_a_failure_under_the_failsafe_without_a_cause_is_offboard_lost_after_the_wait() -> None:
    """No other cause: the FCU's failsafe took the vehicle for a reason of its own (its
    offboard-loss failsafe); with no resumes allowed, its permanent reaction at once."""
    rig = exploring()
    rig.feed(FAILSAFE)
    rig.done(Outcome.FAILED, "no way on")
    rig.tick(PARAMS.failure_cause_wait_s - 0.1)
    assert rig.state == "mission.explore"
    rig.tick(0.2)
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert stop.cause is ErrorCause.OFFBOARD_LOST
    assert stop.detail.startswith("explore: no way on") and "failsafe" in stop.detail


def test_pictures_are_those_of_the_target_since_the_exploration_the_latest_kept() -> None:
    rig = Rig()
    rig.feed(RobotSeen(19, "before"))  # not exploring yet: not kept
    assert rig.driver.pictures == []
    rig = exploring()
    for picture in ("a", "b", "c"):
        rig.feed(RobotSeen(19, picture))
    rig.feed(RobotSeen(13, "other"))
    rig.done(Outcome.MARKER_FOUND)
    rig.feed(RobotSeen(19, "d"))
    out = rig.woke()
    assert of(out, SendPictures)[0].pictures == ("b", "c", "d")  # max_pictures = 3
    rig.feed(RobotSeen(19, "late"))  # the report is over
    assert rig.driver.pictures == ["b", "c", "d"]


def test_a_new_exploration_forgets_the_pictures_of_the_previous_one() -> None:
    rig = exploring()
    rig.feed(RobotSeen(19, "old"))
    rig.feed(OperatorCommand(Order.PAUSE))
    rig.feed(OperatorCommand(Order.RESUME))
    assert rig.driver.pictures == []


def test_without_a_picture_the_report_waits_then_sends_the_robot_id_and_position() -> None:
    rig = exploring()
    rig.feed(Position((6.0, 4.0, 1.5)))
    rig.done(Outcome.MARKER_FOUND)
    assert rig.job == Sleep(PARAMS.report_hover_s, job=rig.job.job)
    polls = 0
    out = rig.woke()
    while not of(out, SendPictures):
        assert rig.job == Sleep(PICTURE_POLL_S, job=rig.job.job)
        polls += 1
        out = rig.woke()
    assert polls == round(PARAMS.picture_timeout_s / PICTURE_POLL_S)
    assert of(out, SendPictures)[0].pictures == (NoPicture(19, 6.0, 4.0),)
    (warning,) = rig.events(EventKind.ERROR)
    assert warning.severity is Severity.WARN and warning.marker_id == 19
    assert warning.message == ("no picture of robot 19 from perception after 2 s: its ID and "
                               "our position sent")  # 1 s hover + 0.5 s wait
    assert rig.state == "mission.await_sequence"
    assert rig.events(EventKind.PICTURES_SENT)


def test_without_a_position_the_robot_is_sent_without_one() -> None:
    rig = exploring()
    rig.driver.position = None
    rig.done(Outcome.MARKER_FOUND)
    out = rig.woke()
    while not of(out, SendPictures):
        out = rig.woke()
    (no_picture,) = of(out, SendPictures)[0].pictures
    assert no_picture.marker_id == 19 and math.isnan(no_picture.x) and math.isnan(no_picture.y)


def test_a_picture_during_the_wait_ends_it() -> None:
    rig = exploring()
    rig.done(Outcome.MARKER_FOUND)
    rig.woke()
    rig.feed(RobotSeen(19, "late but there"))
    out = rig.woke()
    assert of(out, SendPictures)[0].pictures == ("late but there",)
    assert not rig.events(EventKind.ERROR)


# -- the sequence --------------------------------------------------------------------------
def test_the_operator_silent_past_the_sequence_timeout_returns_home() -> None:
    rig = awaiting_sequence()
    entered = rig.t_ns
    rig.tick(after_s=PARAMS.sequence_timeout_s)  # at the timeout: still waiting
    assert rig.state == "mission.await_sequence"
    assert rig.t_ns - entered == 120_000_000_000
    out = rig.tick(after_s=50e-9)  # from the first nanoseconds past it
    assert rig.state == "returning.navigate"
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.SEQUENCE_TIMEOUT
    assert stop.detail == "no landing sequence after 120 s"
    assert of(out, SendGoal)[0].goal == NavigateGoal((1.5, 1.5, 1.5))


def test_a_pad_without_a_path_is_skipped_with_the_reason() -> None:
    rig = flying_pads()
    out = rig.done(Outcome.NO_PATH, "goal inside an obstacle")
    (skipped,) = rig.driver.mission.skipped
    assert skipped.pad == 2 and skipped.reason == "no path: goal inside an obstacle"
    assert rig.state == "mission.pad.navigate"
    assert of(out, SendGoal)[0].goal == NavigateGoal((7.0, 10.5, 1.5))  # the next pad


@pytest.mark.parametrize("not_seen", [Outcome.MARKER_NOT_FOUND, Outcome.MARKER_LOST])
def test_a_pad_not_seen_is_searched_for_then_skipped_and_after_the_last_home(
        not_seen: Outcome) -> None:
    """A marker never seen and one lost in the descent are both "marker not found"."""
    rig = flying_pads(pads=(3,), points=(20,))
    rig.done()
    out = rig.done(not_seen, "marker never seen")
    assert rig.state == "mission.pad.search"
    assert of(out, SendGoal)[0].goal == PrecisionLandGoal(3, (7.0, 10.5), 2.0)
    out = rig.done(not_seen, "still not")
    (skipped,) = rig.driver.mission.skipped
    assert skipped.pad == 3 and skipped.reason.endswith("of its known position: still not")
    snapshot = rig.driver.snapshot(rig.t_ns)
    assert snapshot.pads_skipped == (3,)
    assert rig.state == "returning.navigate"
    assert of(out, SendGoal)[0].goal == NavigateGoal((1.5, 1.5, 1.5))
    rig.done()
    out = rig.done(not_seen, "start pad not seen")
    assert rig.state == "landing_now"
    assert of(out, SendGoal) == [SendGoal(rig.job.job, Action.LAND, LandGoal(0.4, True))]
    rig.done()
    assert rig.state == "completed"  # the sequence is over


def test_a_failed_landing_where_the_vehicle_is_holds() -> None:
    rig = exploring()
    rig.feed(replace(FLYING, battery_warning=2, battery_remaining=0.05))
    rig.tick()
    assert rig.state == "landing_now"
    rig.failed("no touchdown detected")
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert (stop.cause, stop.detail) == (ErrorCause.FLIGHT_ERROR, "land: no touchdown detected")


def test_a_precision_landing_failure_names_the_pad() -> None:
    rig = flying_pads()
    rig.done()
    rig.failed("descent timeout")
    stop = rig.driver.mission.stop
    assert stop is not None and stop.detail == "precision land on pad 2: descent timeout"


# -- errors: the policy's reactions --------------------------------------------------------
def test_a_failed_navigation_holds_and_cancels_what_runs() -> None:
    rig = flying_pads()
    out = rig.failed("blocked")
    assert rig.state == "stopped"
    assert of(out, CancelGoal) == [CancelGoal()]
    stop = rig.driver.mission.stop
    assert stop is not None and stop.reaction is Reaction.HOLD
    assert stop.detail == "navigate: blocked"
    assert not of(out, JOBS)
    assert rig.done() == []  # a second answer: nothing waits for it any more


@pytest.mark.parametrize(("status", "cause", "state", "detail"), [
    (replace(FLYING, battery_warning=1, battery_remaining=0.6), ErrorCause.BATTERY_LOW,
     "returning.navigate", "battery low (60 %)"),
    (replace(FLYING, battery_warning=2, battery_remaining=math.nan),
     ErrorCause.BATTERY_CRITICAL, "landing_now", "battery critical (unknown)"),
    (replace(FLYING, battery_warning=3, battery_remaining=0.01),
     ErrorCause.BATTERY_CRITICAL, "landing_now", "battery critical (1 %)"),
    (replace(FLYING, position_valid=False), ErrorCause.LOCALISATION_LOST, "stopped",
     "the FCU's position estimate is not valid (visual odometry lost)"),
])
def test_an_alert_goes_through_the_error_policy(status: VehicleStatus, cause: ErrorCause,
                                                state: str, detail: str) -> None:
    rig = exploring()
    rig.feed(status)
    out = rig.tick()
    assert rig.state == state
    stop = rig.driver.mission.stop
    assert stop is not None and (stop.cause, stop.detail) == (cause, detail)
    if state == "landing_now":
        assert of(out, SendGoal)[0].goal == LandGoal(0.4, True)


def test_a_module_reporting_an_error_holds() -> None:
    rig = exploring()
    rig.feed(Health(TOPICS[0], False, True, "offboard lost"))
    rig.watchdog(0.1)
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert (stop.cause, stop.detail) == (ErrorCause.MODULE_ERROR,
                                         "/flight_control/health: offboard lost")


def test_a_module_reporting_a_warning_is_no_alert() -> None:
    rig = exploring()
    rig.report_health(ok=False, error=False, message="slow")
    rig.watchdog(0.1)
    assert rig.state == "mission.explore"


def test_a_module_silent_past_its_timeout_holds() -> None:
    rig = exploring()
    rig.report_health()
    rig.watchdog(PARAMS.silence_timeout_s)  # at the timeout: still alive
    assert rig.state == "mission.explore"
    rig.watchdog(2e-9)  # from the first nanoseconds past it
    stop = rig.driver.mission.stop
    assert rig.state == "stopped" and stop is not None
    assert (stop.cause, stop.detail) == (ErrorCause.MODULE_SILENT,
                                         "/flight_control/health: no report for 3.0 s")


def test_a_module_that_never_reported_is_silent() -> None:
    rig = Rig(replace(PARAMS, health_topics=(*TOPICS, "/mapping/health")))
    rig.report_health()  # all but /mapping/health
    rig.feed(FLYING)
    assert rig.driver.alerts() == [(ErrorCause.MODULE_SILENT,
                                    "/mapping/health: no report for ever")]


def test_alerts_come_gravest_first_and_the_first_stop_ends_the_checks() -> None:
    rig = exploring()
    rig.feed(Health(TOPICS[1], False, True, "planner crashed"))
    rig.feed(replace(FLYING, position_valid=False, battery_warning=1, battery_remaining=0.3))
    assert [c for c, _ in rig.driver.alerts()] == [
        ErrorCause.LOCALISATION_LOST, ErrorCause.MODULE_ERROR, ErrorCause.BATTERY_LOW]
    rig.watchdog(0.1)
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.LOCALISATION_LOST
    assert len(rig.events(EventKind.MODULE_FAULT)) == 0  # never applied: already stopped


def test_a_module_error_acts_before_a_low_battery() -> None:
    rig = exploring()
    rig.feed(replace(FLYING, battery_warning=1, battery_remaining=0.3))
    rig.feed(Health(TOPICS[1], False, True, "planner crashed"))
    rig.watchdog(0.1)
    assert rig.state == "stopped"
    assert rig.driver.mission.stop is not None
    assert rig.driver.mission.stop.cause is ErrorCause.MODULE_ERROR


def test_no_alert_is_acted_on_before_the_flight_or_after_the_end() -> None:
    rig = Rig()
    rig.feed(replace(ON_GROUND, position_valid=False))
    rig.watchdog(10.0)  # idle: every module silent, no position
    assert rig.state == "idle"
    rig.feed(OperatorCommand(Order.START))
    rig.watchdog(10.0)
    assert rig.state == "preflight"
    rig = flying_pads(pads=(2,), points=(10,))
    rig.done()
    rig.done()
    assert rig.state == "completed"
    rig.feed(replace(FLYING, position_valid=False))
    rig.feed(Tick(), 10.0)
    assert rig.state == "completed" and rig.driver.mission.stop is None


# -- the operator ---------------------------------------------------------------------------
def test_an_abort_mid_sequence_cancels_the_landing_and_drops_its_late_result() -> None:
    rig = flying_pads()
    rig.done()
    landing = rig.job
    assert landing.action is Action.PRECISION_LAND
    out = rig.feed(OperatorCommand(Order.ABORT, reason="a person on the field"))
    assert rig.state == "stopped"
    assert of(out, CancelGoal) == [CancelGoal()]
    assert isinstance(out[-1], PublishState) and out[-1].snapshot.state == "stopped"
    assert not rig.driver.current(landing.job)
    stop = rig.driver.mission.stop
    assert stop is not None and stop.cause is ErrorCause.OPERATOR_ABORT
    assert stop.detail == "a person on the field"
    late = rig.feed(GoalDone(landing.job, Outcome.SUCCEEDED, "", 0.02))
    assert late == [] and rig.driver.mission.landed_pads == []


def test_return_home_mid_sequence_flies_to_the_start_pad() -> None:
    rig = flying_pads()
    out = rig.feed(OperatorCommand(Order.RETURN_HOME))
    assert rig.state == "returning.navigate"
    assert of(out, SendGoal)[0].goal == NavigateGoal((1.5, 1.5, 1.5))
    stop = rig.driver.mission.stop
    assert stop is not None and stop.detail == "operator's RETURN_HOME"
    assert rig.events(EventKind.COMMAND_ACCEPTED)[-1].message == (
        "RETURN_HOME accepted: operator's RETURN_HOME")
    rig = flying_pads()
    rig.feed(OperatorCommand(Order.RETURN_HOME, reason="rain"))
    assert rig.driver.mission.stop is not None and rig.driver.mission.stop.detail == "rain"


def test_pause_cancels_and_resume_starts_the_action_again_in_a_new_job() -> None:
    rig = exploring()
    explore = rig.job
    out = rig.feed(OperatorCommand(Order.PAUSE))
    assert rig.state == "paused" and of(out, CancelGoal) == [CancelGoal()]
    assert not of(out, JOBS)
    out = rig.feed(OperatorCommand(Order.RESUME), 3.0)
    assert rig.state == "mission.explore"
    (again,) = of(out, SendGoal)
    assert again.goal == explore.goal and again.job != explore.job
    assert rig.feed(GoalDone(explore.job, Outcome.MARKER_FOUND, "")) == []  # the old one
    assert rig.state == "mission.explore"
    rig.done(Outcome.MARKER_FOUND)
    assert rig.state == "mission.report_robot"


def test_an_unknown_command_is_rejected_and_every_command_publishes_the_state() -> None:
    rig = Rig()
    out = rig.feed(UnknownCommand(9))
    assert [type(c) for c in out] == [PublishEvent, PublishState]
    assert out[0].event.kind is EventKind.COMMAND_REJECTED
    assert out[0].event.message == "unknown command 9" and out[0].event.severity is Severity.WARN
    out = rig.feed(OperatorCommand(Order.RESUME))
    assert [type(c) for c in out] == [PublishEvent, PublishState]
    assert out[0].event.message.startswith("RESUME rejected")


def test_elapsed_counts_from_an_accepted_start_only() -> None:
    rig = Rig()
    rig.feed(OperatorCommand(Order.START), after_s=2.0)
    started_ns = rig.t_ns
    rig.feed(OperatorCommand(Order.START), after_s=3.0)  # rejected: the clock keeps running
    assert rig.out[-1].snapshot.elapsed_ns == rig.t_ns - started_ns == 3_000_000_000


# -- jobs ----------------------------------------------------------------------------------
def test_an_answer_counts_once_and_only_for_the_job_in_hand() -> None:
    assert Rig().feed(Woke(0)) == []  # nothing asked yet
    rig = started()
    probe = rig.job
    assert rig.driver.current(probe.job)
    assert rig.feed(Probed(probe.job + 1, ())) == []  # not the job in hand
    assert rig.state == "preflight"
    rig.feed(Probed(probe.job, ("navigate",)))
    sleep = rig.job
    assert rig.feed(Probed(probe.job, ())) == []  # the job now waits on its sleep
    assert rig.state == "preflight"
    rig.woke()
    assert rig.feed(Woke(sleep.job)) == []  # woken twice: once counts
    rig.feed(Probed(probe.job, ()))
    assert rig.state == "mission.takeoff"


def test_a_job_ended_while_arming_sends_no_takeoff() -> None:
    rig = started()
    rig.feed(Probed(rig.job.job, ()))
    arming = rig.job
    rig.feed(OperatorCommand(Order.PAUSE))
    assert rig.feed(ArmDone(arming.job, None)) == []


def test_hold_opens_no_job() -> None:
    rig = awaiting_sequence()  # hold on entry
    job = rig.driver.job
    rig.driver.hold()
    assert rig.driver.job == job


def test_the_driver_is_pure_the_machine_the_policy_words_and_the_standard_library_only(
        ) -> None:
    tree = ast.parse(Path(mission_driver.__file__).read_text(encoding="utf-8"))
    imported = {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    project = {"interfaces", "runtime", "sim", "flight_control", "perception", "navigation",
               "fsm", "ground_station", "quadmission"}
    assert {m for m in imported if m.split(".")[0] in project} == {
        "flight_control.policy", "fsm.mission_machine", "fsm.mission_table"}
    assert not {m for m in imported if m.split(".")[0] in ("mujoco", "rclpy", "rosbags")}


@pytest.mark.parametrize("action", list(Action))
def test_a_rejected_goal_failed_whatever_its_default_code_says(action: Action) -> None:
    """A rejected goal's result is the default one (code 0): for explore that code reads
    "area covered", which would send the mission home as "robot not found"."""
    every_code_ends = dict.fromkeys(range(4), Outcome.COVERED)
    assert mission_driver.goal_outcome(action, accepted=False, success=False, code=0,
                                       codes=every_code_ends) is Outcome.FAILED


def test_a_finished_goal_reads_as_its_code_and_explore_only_by_its_code() -> None:
    codes = {0: Outcome.COVERED, 2: Outcome.NO_PATH}
    outcome = mission_driver.goal_outcome
    assert outcome(Action.NAVIGATE, accepted=True, success=True, code=0,
                   codes=codes) is Outcome.SUCCEEDED
    assert outcome(Action.NAVIGATE, accepted=True, success=False, code=2,
                   codes=codes) is Outcome.NO_PATH
    assert outcome(Action.NAVIGATE, accepted=True, success=False, code=1,
                   codes=codes) is Outcome.FAILED  # a code with no meaning of its own
    # explore: success says the action ran; its code says whether the robot was found
    assert outcome(Action.EXPLORE, accepted=True, success=True, code=0,
                   codes=codes) is Outcome.COVERED
