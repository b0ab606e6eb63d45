"""The navigator's policies (navigation/navigator_policy.py) walked tick by tick, without
the runtime: the test answers each command as the planner and the flight-control actions
would (the node does it for real in tests/navigation/test_navigator_flight.py)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from flight_control.policy import Finish, Log, Outcome, PolicyError, Sleep
from navigation.astar import path_length
from navigation.coverage import lane_spacing
from navigation.navigator_policy import (
    EXPLORE_INTERRUPTED,
    EXPLORE_OUTCOMES,
    LANE_STEP_M,
    NAVIGATE_OUTCOMES,
    POLL_S,
    SURVEY_OUTCOMES,
    ActionState,
    CancelAction,
    Command,
    ExploreFinish,
    ExplorePolicy,
    ExploreProgress,
    ExploreSoFar,
    ExploreTuning,
    FollowTuning,
    Inputs,
    NavigatePolicy,
    NavigateProgress,
    Plan,
    Planned,
    PollAction,
    SendReach,
    SendTurn,
    Sent,
    SurveyPolicy,
    explore_waypoints,
    lane_points,
)
from navigation.params import NavigatorParams

FOLLOW = FollowTuning(plan_attempts=3, replan_period_s=1.0, replan_tolerance=0.5,
                      map_wait_s=1.0, turn_first_angle=0.785, waypoint_radius=0.3,
                      corner_cut=0.1, goal_radius=0.15, cruise_speed=1.0, max_reach_failures=1,
                      pass_stop_s=0.5)
EXPLORE = ExploreTuning(explore_sweeps=3, replace_blocked_lane_ends=False, coverage_cell=0.25,
                        down_camera_fovy_deg=60.0, down_camera_aspect=4.0 / 3.0,
                        lane_overlap=0.2, lane_point_spacing=3.0, wall_margin=1.0, arena="",
                        start_pad=0)
Z = 1.5
HERE = np.array([0.0, 0.0, Z])
GOAL = np.array([4.0, 0.0, Z])
#: The outcomes each policy names as its ends.
ENDS = {NavigatePolicy: NAVIGATE_OUTCOMES, SurveyPolicy: SURVEY_OUTCOMES,
        ExplorePolicy: EXPLORE_OUTCOMES}


def p(*xy: tuple[float, float]) -> np.ndarray:
    """A path (N, 3) at Z through the points ``xy``."""
    return np.array([[x, y, Z] for x, y in xy])


def ok(path: np.ndarray, stamp_ns: int = 0) -> Planned:
    return Planned(path, "found", stamp_ns)


def failed(message: str = "NoPathFound", *, blocks_leg: bool = True) -> Planned:
    return Planned(None, message, 0, blocks_leg)


class Stepper:
    """Feeds a policy one step at a time: the time, the pose, the cancel request and the
    markers are the test's to set between steps."""

    def __init__(self, policy: Any, here: np.ndarray = HERE, yaw: float = 0.0) -> None:
        self.policy = policy
        self.now_ns = 0
        self.position = np.array(here, dtype=np.float64)
        self.yaw = yaw
        self.cancel = False
        self.markers: dict[int, int] = {}

    def __call__(self, answer: Any = None) -> Command:
        command = self.policy.step(Inputs(self.now_ns, self.position.copy(), self.yaw,
                                          self.cancel, dict(self.markers), answer))
        if isinstance(command, Finish):  # every end a test walks to is one its policy names
            assert command.outcome in ENDS[type(self.policy)], command
        return command

    def wait(self, seconds: float) -> None:
        self.now_ns += round(seconds * 1e9)


class World(Stepper):
    """Answers every command: plans with ``planner(start, goal, world)``, accepts every
    flight goal, which ends after ``polls`` polls (a reach there, a turn facing its yaw)
    with success unless ``fail`` says otherwise. ``during(world)`` runs before each step.
    ``log`` holds the commands."""

    def __init__(self, policy: Any, planner: Callable[[np.ndarray, np.ndarray, World], Planned],
                 *, here: np.ndarray = HERE, yaw: float = 0.0, polls: int = 5,
                 during: Callable[[World], None] | None = None) -> None:
        super().__init__(policy, here, yaw)
        self.planner = planner
        self.polls = polls
        self.during = during
        self.fail: Callable[[Any], str | None] = lambda _command: None  # a message: fails
        self.log: list[Command] = []
        self.times: list[int] = []  # ns, when each command of ``log`` was given
        self.flying: Any = None
        self.polled = 0
        self.reached = 0  # reaches ended with success
        self._from = self.position

    def run(self, limit: int = 20_000) -> Finish:
        answer: Any = None
        for _ in range(limit):
            if self.during is not None:
                self.during(self)
            command = self(answer)
            self.log.append(command)
            self.times.append(self.now_ns)
            if isinstance(command, Finish):
                return command
            answer = self.carry_out(command)
        raise AssertionError("the policy never finished")

    def carry_out(self, command: Command) -> Any:
        if isinstance(command, Plan):
            return self.planner(command.start, command.goal, self)
        if isinstance(command, Sleep):
            self.wait(command.seconds)
        elif isinstance(command, SendReach | SendTurn):
            self.flying, self.polled, self._from = command, 0, self.position
            return Sent(True)
        elif isinstance(command, PollAction):
            self.polled += 1
            if self.polled < self.polls:
                if isinstance(self.flying, SendReach):  # on the way, in a straight line
                    self.position = self._from + (self.flying.target - self._from) * (
                        self.polled / self.polls)
                return ActionState(False)
            why = self.fail(self.flying)
            if why is not None:
                return ActionState(True, False, why)
            if isinstance(self.flying, SendReach):
                self.position = np.array(self.flying.target, dtype=np.float64)
                self.reached += 1
            else:
                self.yaw = self.yaw + self.flying.yaw if self.flying.relative else self.flying.yaw
            return ActionState(True, True, "done")
        elif isinstance(command, CancelAction):
            self.flying = None
        return None

    def of(self, kind: type) -> list[Any]:
        return [c for c in self.log if isinstance(c, kind)]


def straight(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
    """A clear map, updated as the policy asks."""
    return ok(np.array([start, goal]), stamp_ns=world.now_ns)


def first_then_straight(path: np.ndarray) -> Callable[[np.ndarray, np.ndarray, World], Planned]:
    """A planner that answers ``path`` first, then straight lines (a clear map)."""
    return lambda s, g, w: ok(path) if len(w.of(Plan)) == 1 else straight(s, g, w)


def navigate(goal: np.ndarray = GOAL, follow: FollowTuning = FOLLOW, **kwargs: Any
             ) -> NavigatePolicy:
    return NavigatePolicy(follow, goal, radius=kwargs.pop("radius", 0.2),
                          speed=kwargs.pop("speed", 1.0), **kwargs)


def fly_leg(step: Stepper, path: np.ndarray) -> SendReach:
    """From the start of a navigate goal: plan ``path`` and answer up to its first reach."""
    assert isinstance(step(), Plan)
    reach = step(ok(path))
    assert isinstance(reach, SendReach)
    assert isinstance(step(Sent(True)), PollAction)
    return reach


def poll_until_replan(step: Stepper) -> Plan:
    """Answer 'still flying' until the policy plans again; the replan period passes."""
    for _ in range(round(FOLLOW.replan_period_s / POLL_S) + 1):
        command = step(ActionState(False))
        assert isinstance(command, NavigateProgress)
        command = step()
        if isinstance(command, Plan):
            return command
        assert command == Sleep(POLL_S)
        step.wait(POLL_S)
        assert isinstance(step(), PollAction)
    raise AssertionError("no re-plan within the replan period")


# -- following a path ----------------------------------------------------------------------
def test_arrival_flies_each_waypoint_then_finishes_reached() -> None:
    path = p((0, 0), (2, 0), (2, 2))
    world = World(navigate(p((2, 2))[0]), first_then_straight(path))
    end = world.run()
    assert end == Finish(Outcome.SUCCEEDED, "reached")
    reaches = world.of(SendReach)
    assert [r.target.tolist() for r in reaches] == [[2, 0, Z], [2, 2, Z]]
    # the right-angle corner: the vehicle stops there and the sphere shrinks to the cut
    assert reaches[0].stop_at_target and reaches[0].radius == pytest.approx(FOLLOW.corner_cut)
    assert reaches[1].stop_at_target and reaches[1].radius == 0.2  # the goal's radius
    assert reaches[0].yaw == 0.0 and reaches[1].yaw == pytest.approx(math.pi / 2)
    assert reaches[1].speed == 1.0
    assert world.of(SendTurn) == [SendTurn(math.pi / 2)]  # faced the leg north first
    assert np.allclose(world.position, (2, 2, Z))


def test_a_gentle_corner_is_passed_through_inside_the_waypoint_sphere() -> None:
    path = p((0, 0), (2, 0), (4, 0.2))
    world = World(navigate(p((4, 0.2))[0]), first_then_straight(path))
    assert world.run().outcome is Outcome.SUCCEEDED
    first = world.of(SendReach)[0]
    assert not first.stop_at_target and first.radius == FOLLOW.waypoint_radius
    assert world.of(SendTurn) == []


def test_a_turn_first_angle_of_pi_never_turns_first() -> None:
    follow = FollowTuning(**{**FOLLOW.__dict__, "turn_first_angle": 3.15})
    world = World(navigate(p((-3, 0))[0], follow), straight, yaw=0.0)
    assert world.run().outcome is Outcome.SUCCEEDED
    assert world.of(SendTurn) == [] and world.of(SendReach)[0].yaw == pytest.approx(math.pi)


def test_a_waypoint_right_above_keeps_the_heading() -> None:
    world = World(navigate(np.array([2.1, 2.0, 3.0])), straight, here=np.array([2.0, 2.0, Z]),
                  yaw=2.0)
    assert world.run().outcome is Outcome.SUCCEEDED
    assert world.of(SendTurn) == [] and world.of(SendReach)[0].yaw == 2.0


def test_a_waypoint_0_3_m_away_is_faced() -> None:
    world = World(navigate(np.array([0.3, 0.0, Z])), straight, yaw=2.0)
    assert world.run().outcome is Outcome.SUCCEEDED
    assert world.of(SendTurn) == [SendTurn(0.0)]


def test_a_leg_faced_exactly_is_not_turned_to_and_a_straight_waypoint_is_no_corner() -> None:
    follow = FollowTuning(**{**FOLLOW.__dict__, "turn_first_angle": 0.0})
    world = World(navigate(GOAL, follow), first_then_straight(p((0, 0), (2, 0), (4, 0))))
    assert world.run().outcome is Outcome.SUCCEEDED
    assert world.of(SendTurn) == []
    assert not world.of(SendReach)[0].stop_at_target


def test_plan_failures_are_retried_then_the_goal_ends_with_no_path() -> None:
    world = World(navigate(), lambda s, g, w: failed("GoalOccupied: in the wall"))
    end = world.run()
    assert end == Finish(Outcome.NO_PATH, "GoalOccupied: in the wall")
    # plan_attempts plans, replan_period_s apart; no wait after the last
    assert [type(c) for c in world.log] == ([Plan, Sleep] * (FOLLOW.plan_attempts - 1)
                                            + [Plan, Finish])
    assert world.of(Sleep) == [Sleep(FOLLOW.replan_period_s)] * (FOLLOW.plan_attempts - 1)
    assert all(np.array_equal(c.start, HERE) and np.array_equal(c.goal, GOAL)
               for c in world.of(Plan))


def test_the_last_plan_attempt_that_succeeds_is_flown() -> None:
    world = World(navigate(), lambda s, g, w: ok(np.array([s, g]))
                  if len(w.of(Plan)) == FOLLOW.plan_attempts else failed())
    assert world.run().outcome is Outcome.SUCCEEDED
    assert len(world.of(Sleep)) >= FOLLOW.plan_attempts - 1


def test_a_goal_that_is_not_finite_has_no_path_and_is_not_planned() -> None:
    world = World(navigate(np.array([1.0, math.nan, Z])), straight)
    assert world.run() == Finish(Outcome.NO_PATH, "goal is not finite")
    assert world.log == [Finish(Outcome.NO_PATH, "goal is not finite")]


def test_after_the_end_every_step_answers_the_same_finish() -> None:
    step = Stepper(navigate(np.array([1.0, math.nan, Z])))
    end = step()
    assert isinstance(end, Finish) and step() is end and step(ok(p((0, 0)))) is end


def test_a_wrong_answer_is_an_error_that_names_what_was_expected() -> None:
    step = Stepper(navigate())
    assert isinstance(step(), Plan)
    with pytest.raises(PolicyError, match="Planned"):
        step(Sent(True))


def test_a_rejected_reach_is_a_flight_error() -> None:
    step = Stepper(navigate())
    assert isinstance(step(), Plan)
    assert isinstance(step(ok(np.array([HERE, GOAL]))), SendReach)
    assert step(Sent(False, "not armed")) == Finish(Outcome.FLIGHT_ERROR,
                                                     "reach rejected: not armed")


def test_a_failed_reach_is_replanned_from_here_then_a_second_one_is_a_flight_error() -> None:
    world = World(navigate(), straight)
    world.fail = lambda command: "lost offboard" if isinstance(command, SendReach) else None
    end = world.run()
    assert end == Finish(Outcome.FLIGHT_ERROR, "reach failed: lost offboard")
    assert len(world.of(SendReach)) == FOLLOW.max_reach_failures + 1
    assert len(world.of(Plan)) == 1 + FOLLOW.max_reach_failures  # the first plan + 1 re-plan


def test_a_failed_reach_that_cannot_be_replanned_has_no_path() -> None:
    world = World(navigate(), lambda s, g, w: ok(np.array([s, g])) if not w.of(SendReach)
                  else failed("StartOccupied"))
    world.fail = lambda command: "lost offboard"
    assert world.run() == Finish(Outcome.NO_PATH, "StartOccupied")


def test_a_reach_failed_once_and_replanned_reaches_the_goal() -> None:
    world = World(navigate(), straight)
    world.fail = lambda command: "bumped" if len(world.of(SendReach)) == 1 else None
    assert world.run() == Finish(Outcome.SUCCEEDED, "reached")
    assert len(world.of(SendReach)) == 2


def test_cancel_on_the_way_cancels_the_reach_and_ends_canceled() -> None:
    step = Stepper(navigate())
    fly_leg(step, np.array([HERE, GOAL]))
    step.cancel = True
    assert isinstance(step(ActionState(False)), CancelAction)
    assert step() == Finish(Outcome.CANCELED, "stopped on the way")


def test_progress_says_the_waypoint_and_what_is_left_of_the_path() -> None:
    step = Stepper(navigate())
    fly_leg(step, p((0, 0), (2, 0.5), (4, 0)))
    step.position = np.array([1.0, 0.0, Z])
    progress = step(ActionState(False))
    assert isinstance(progress, NavigateProgress) and progress.waypoint == 1
    assert np.array_equal(progress.path, p((0, 0), (2, 0.5), (4, 0)))
    assert progress.distance_left == pytest.approx(math.hypot(1.0, 0.5) + math.hypot(2.0, 0.5))


def test_no_replan_before_the_period_then_one_each_period() -> None:
    step = Stepper(navigate())
    fly_leg(step, np.array([HERE, GOAL]))
    polls = 0
    while True:
        assert isinstance(step(ActionState(False)), NavigateProgress)
        command = step()
        if isinstance(command, Plan):
            break
        polls += 1
        step.wait(POLL_S)
        assert isinstance(step(), PollAction)
    assert step.now_ns == round(FOLLOW.replan_period_s * 1e9)
    assert polls == round(FOLLOW.replan_period_s / POLL_S)
    assert isinstance(step(ok(np.array([HERE, GOAL]))), Plan)  # the same path: the leg check
    assert step(ok(np.array([HERE, GOAL]))) == Sleep(POLL_S)
    step.wait(POLL_S)
    assert isinstance(step(), PollAction)
    replanned_ns = step.now_ns - round(POLL_S * 1e9)
    poll_until_replan(step)  # the next one a whole period after the last
    assert step.now_ns == replanned_ns + round(FOLLOW.replan_period_s * 1e9)


# -- re-planning while a leg is flown ------------------------------------------------------
def test_a_blocked_leg_switches_to_a_detour_of_the_same_length() -> None:
    """The blind spot of the flights: the new path is as long as what is left of the old
    one (a detour mirrored round the other side), so only the blocked leg can make the
    switch. The policy cancels the reach and flies the detour's first waypoint."""
    old = p((0, 0), (2, 1), (4, 0))
    detour = p((0, 0), (2, -1), (4, 0))
    assert path_length(detour) == path_length(old)  # the same length, to the last bit
    step = Stepper(navigate())
    fly_leg(step, old)
    replan = poll_until_replan(step)
    assert np.array_equal(replan.start, HERE) and np.array_equal(replan.goal, GOAL)
    leg_check = step(ok(detour))
    assert isinstance(leg_check, Plan) and np.array_equal(leg_check.goal, old[1])
    # the planner can no longer go straight to the leg's end: round a new obstacle
    assert isinstance(step(ok(p((0, 0), (1, 1), (2, 1)))), CancelAction)
    switched = step()
    assert isinstance(switched, SendReach)
    assert np.array_equal(switched.target, detour[1])


def test_a_clear_leg_and_a_new_path_of_the_same_length_keep_the_old_path() -> None:
    old = p((0, 0), (2, 1), (4, 0))
    step = Stepper(navigate())
    fly_leg(step, old)
    poll_until_replan(step)
    assert isinstance(step(ok(p((0, 0), (2, -1), (4, 0)))), Plan)
    assert step(ok(np.array([HERE, old[1]]))) == Sleep(POLL_S)  # flies on, no cancel


@pytest.mark.parametrize(("longer", "switch"),
                         [(0.4, False), (0.6, True), (-0.4, False), (-0.6, True)])
def test_a_clear_leg_switches_when_the_new_length_differs_by_more_than_the_tolerance(
        longer: float, switch: bool) -> None:
    old = p((0, 0), (2, 1.5), (4, 0))  # 5 m
    step = Stepper(navigate())
    fly_leg(step, old)
    poll_until_replan(step)
    new = p((0, 0), (2, -math.sqrt(((5 + longer) / 2) ** 2 - 4)), (4, 0))
    assert path_length(new) == pytest.approx(5 + longer)
    assert isinstance(step(ok(new)), Plan)
    command = step(ok(np.array([HERE, old[1]])))  # the leg is clear
    if switch:
        assert isinstance(command, CancelAction)
        assert np.array_equal(step().target, new[1])  # type: ignore[union-attr]
    else:
        assert command == Sleep(POLL_S)


def test_a_length_difference_of_exactly_the_tolerance_keeps_the_path() -> None:
    follow = FollowTuning(**{**FOLLOW.__dict__, "replan_tolerance": 1.0})
    step = Stepper(navigate(GOAL, follow))
    fly_leg(step, np.array([HERE, GOAL]))  # 4 m
    poll_until_replan(step)
    new = p((0, 0), (2, 1.5), (4, 0))  # 2.5 m + 2.5 m
    assert path_length(new) - 4.0 == 1.0
    assert isinstance(step(ok(new)), Plan)
    assert step(ok(np.array([HERE, GOAL]))) == Sleep(POLL_S)


def test_a_leg_check_failure_that_blocks_the_leg_switches_and_one_that_does_not_flies_on(
        ) -> None:
    for blocks_leg, expected in ((True, CancelAction), (False, Sleep)):
        old = p((0, 0), (2, 1), (4, 0))
        step = Stepper(navigate())
        fly_leg(step, old)
        poll_until_replan(step)
        assert isinstance(step(ok(p((0, 0), (2, -1), (4, 0)))), Plan)
        assert isinstance(step(failed(blocks_leg=blocks_leg)), expected), blocks_leg


def test_a_failed_replan_on_a_clear_leg_flies_on() -> None:
    step = Stepper(navigate())
    fly_leg(step, np.array([HERE, GOAL]))
    poll_until_replan(step)
    assert isinstance(step(failed(blocks_leg=False)), Plan)  # the leg is still checked
    assert step(ok(np.array([HERE, GOAL]))) == Sleep(POLL_S)


def test_a_leg_whose_end_is_no_longer_free_is_blocked() -> None:
    """The planner snaps an end that is in or too near an obstacle to the free cube beside
    it: a straight 2-point plan that ends elsewhere says the leg's end is no longer free
    (random arena 100: the corner beside a block whose face had just been mapped)."""
    old = p((0, 0), (2, 1), (4, 0))
    step = Stepper(navigate())
    fly_leg(step, old)
    poll_until_replan(step)
    detour = p((0, 0), (2, -1), (4, 0))
    assert isinstance(step(ok(detour)), Plan)
    assert isinstance(step(ok(p((0, 0), (2, 1.2)))), CancelAction)  # snapped 0.2 m away
    assert np.array_equal(step().target, detour[1])  # type: ignore[union-attr]


def test_each_leg_after_the_first_is_checked_on_the_map_as_it_is_before_it_is_flown(
        ) -> None:
    """The map grows while a leg is flown; the next leg is judged on it before its reach,
    not up to a replan period later (random arena 100's last leg lasted 0.4 s)."""
    old = p((0, 0), (2, 0), (4, 0))
    step = Stepper(navigate())
    fly_leg(step, old)
    step.position = old[1].copy()
    replan = step(ActionState(True, True, "reached"))  # leg 1 done within the period
    assert isinstance(replan, Plan)
    assert np.array_equal(replan.start, old[1]) and np.array_equal(replan.goal, GOAL)
    leg_check = step(failed("GoalOccupied"))  # the goal turned out to be in a block
    assert isinstance(leg_check, Plan) and np.array_equal(leg_check.goal, old[2])
    hold = step(failed("GoalOccupied"))  # no reach into it: hold where it is
    assert isinstance(hold, SendReach) and np.array_equal(hold.target, old[1])


def test_a_leg_after_the_first_still_clear_is_flown_without_a_hold() -> None:
    old = p((0, 0), (2, 0), (4, 0))
    world = World(navigate(), first_then_straight(old))
    assert world.run().outcome is Outcome.SUCCEEDED
    assert [r.target.tolist() for r in world.of(SendReach)] == [[2, 0, Z], [4, 0, Z]]
    plans = world.of(Plan)  # the plan, then the goal and the leg checked at (2, 0)
    assert len(plans) == 3 and np.array_equal(plans[1].start, old[1])
    assert np.array_equal(plans[2].goal, old[2])


def blocked_with_no_new_path(step: Stepper) -> SendReach:
    """Fly, re-plan (fails), find the leg blocked: the policy cancels and holds."""
    fly_leg(step, np.array([HERE, GOAL]))
    step.position = np.array([1.0, 0.0, Z])
    step.yaw = 0.3
    poll_until_replan(step)
    assert isinstance(step(failed("NoPathFound: cut off")), Plan)
    assert isinstance(step(failed("GoalOccupied")), CancelAction)
    hold = step()
    assert isinstance(hold, SendReach)
    return hold


def test_a_blocked_leg_with_no_new_path_holds_then_plans_again_then_gives_up() -> None:
    step = Stepper(navigate())
    hold = blocked_with_no_new_path(step)
    assert np.array_equal(hold.target, step.position) and hold.yaw == 0.3
    assert hold.stop_at_target and hold.radius == FOLLOW.goal_radius
    assert hold.speed == FOLLOW.cruise_speed
    assert isinstance(step(Sent(True)), PollAction)
    for attempt in range(FOLLOW.plan_attempts):
        command = step(ActionState(True, True, "held") if attempt == 0 else None)
        assert isinstance(command, Plan), attempt
        assert np.array_equal(command.start, step.position) and np.array_equal(command.goal, GOAL)
        if attempt + 1 < FOLLOW.plan_attempts:  # replan_period_s apart, none after the last
            assert step(failed(f"NoPathFound {attempt}")) == Sleep(FOLLOW.replan_period_s)
    assert step(failed("NoPathFound 2")) == Finish(
        Outcome.NO_PATH, "the path ahead is blocked and no other path was found: NoPathFound 2")


def test_a_blocked_leg_whose_later_plan_finds_a_path_flies_it() -> None:
    step = Stepper(navigate())
    blocked_with_no_new_path(step)
    assert isinstance(step(Sent(True)), PollAction)
    assert isinstance(step(ActionState(True, True, "held")), Plan)
    assert isinstance(step(failed()), Sleep)
    assert isinstance(step(), Plan)
    detour = p((1, 0), (1, 2), (4, 2), (4, 0))
    reach = step(ok(detour))
    assert isinstance(reach, SendTurn)  # a new path from its first waypoint: face it first
    assert reach.yaw == pytest.approx(math.pi / 2)


def test_cancel_while_blocked_stops_planning_again() -> None:
    step = Stepper(navigate())
    blocked_with_no_new_path(step)
    assert isinstance(step(Sent(True)), PollAction)
    step.cancel = True
    assert step(ActionState(True, True, "held")) == Finish(
        Outcome.NO_PATH, "the path ahead is blocked and no other path was found: ")


def test_a_hold_canceled_by_the_goal_cancel_still_ends_without_a_path() -> None:
    step = Stepper(navigate())
    blocked_with_no_new_path(step)
    step.cancel = True
    assert isinstance(step(Sent(True)), PollAction)
    assert isinstance(step(ActionState(False)), CancelAction)
    assert step().outcome is Outcome.NO_PATH  # type: ignore[union-attr]


# -- turning to face a leg, then looking again ---------------------------------------------
def turned(step: Stepper, path: np.ndarray) -> None:
    """Plan ``path`` (its first leg northward, the vehicle facing east): the policy turns
    to face the leg; the turn takes 1 s."""
    assert isinstance(step(), Plan)
    turn = step(ok(path))
    heading = math.atan2(path[1][1] - path[0][1], path[1][0] - path[0][0])
    assert turn == SendTurn(heading)
    assert isinstance(step(Sent(True)), PollAction)
    step.wait(1.0)
    step.yaw = heading


NORTH = p((0, 0), (0, 4))


def test_after_the_turn_it_waits_for_a_map_captured_after_it_then_checks_the_leg() -> None:
    step = Stepper(navigate(NORTH[1]))
    turned(step, NORTH)
    since_ns = step.now_ns
    look = step(ActionState(True, True, "faced"))
    assert isinstance(look, Plan) and np.array_equal(look.goal, NORTH[1])
    # the map is older than the turn: plan again POLL_S later
    assert step(ok(NORTH, stamp_ns=since_ns - 1)) == Sleep(POLL_S)
    step.wait(POLL_S)
    assert isinstance(step(), Plan)
    leg_check = step(ok(NORTH, stamp_ns=since_ns))  # a map from after the turn
    assert isinstance(leg_check, Plan) and np.array_equal(leg_check.goal, NORTH[1])
    reach = step(ok(NORTH))  # the leg is clear: fly it
    assert isinstance(reach, SendReach) and np.array_equal(reach.target, NORTH[1])


def test_after_the_turn_it_stops_waiting_for_a_new_map_at_map_wait_s() -> None:
    step = Stepper(navigate(NORTH[1]))
    turned(step, NORTH)
    deadline_ns = step.now_ns + round(FOLLOW.map_wait_s * 1e9)
    assert isinstance(step(ActionState(True, True, "faced")), Plan)
    plans = 1
    while True:
        command = step(ok(NORTH, stamp_ns=0))
        if not isinstance(command, Sleep):
            break
        step.wait(POLL_S)
        assert isinstance(step(), Plan)
        plans += 1
    assert isinstance(command, Plan) and np.array_equal(command.goal, NORTH[1])  # leg check
    assert step.now_ns == deadline_ns
    assert plans == round(FOLLOW.map_wait_s / POLL_S) + 1


def test_what_it_sees_after_the_turn_switches_to_a_detour_of_the_same_length() -> None:
    around = p((0, 0), (-1, 2), (0, 4))
    other = p((0, 0), (1, 2), (0, 4))
    step = Stepper(navigate(NORTH[1]))
    turned(step, around)
    assert isinstance(step(ActionState(True, True, "faced")), Plan)
    assert isinstance(step(ok(other, stamp_ns=step.now_ns)), Plan)
    turn = step(ok(p((0, 0), (-0.5, 1), (-1, 2))))  # the leg is blocked: switch
    assert isinstance(turn, SendTurn) and turn.yaw == pytest.approx(math.atan2(2, 1))


def test_a_goal_found_blocked_after_the_turn_holds_and_gives_up_with_no_path() -> None:
    step = Stepper(navigate(NORTH[1]))
    turned(step, NORTH)
    assert isinstance(step(ActionState(True, True, "faced")), Plan)
    assert isinstance(step(Planned(None, "NoPathFound", step.now_ns, True)), Plan)
    hold = step(failed("GoalOccupied"))
    assert isinstance(hold, SendReach) and np.array_equal(hold.target, HERE)
    assert isinstance(step(Sent(True)), PollAction)
    again = step(ActionState(True, True, "held"))
    assert isinstance(again, Plan) and np.array_equal(again.goal, NORTH[1])
    for _ in range(FOLLOW.plan_attempts - 1):
        assert isinstance(step(failed("NoPathFound: cut off")), Sleep)
        assert isinstance(step(), Plan)
    assert step(failed("NoPathFound: cut off")) == Finish(
        Outcome.NO_PATH, "the path ahead is blocked and no other path was found: "
                         "NoPathFound: cut off")


def test_a_failed_turn_still_looks_again_before_the_leg() -> None:
    step = Stepper(navigate(NORTH[1]))
    turned(step, NORTH)
    assert isinstance(step(ActionState(True, False, "too slow")), Plan)


def test_a_rejected_turn_still_looks_again_before_the_leg() -> None:
    step = Stepper(navigate(NORTH[1]))
    assert isinstance(step(), Plan)
    assert isinstance(step(ok(NORTH)), SendTurn)
    assert isinstance(step(Sent(False, "busy")), Plan)


def test_cancel_during_the_turn_cancels_it_and_ends_canceled() -> None:
    step = Stepper(navigate(NORTH[1]))
    turned(step, NORTH)
    step.cancel = True
    assert isinstance(step(ActionState(False)), CancelAction)
    assert step() == Finish(Outcome.CANCELED, "canceled")


def test_cancel_while_waiting_for_the_map_flies_no_leg() -> None:
    step = Stepper(navigate(NORTH[1]))
    turned(step, NORTH)
    assert isinstance(step(ActionState(True, True, "faced")), Plan)
    step.cancel = True
    reach = step(ok(NORTH, stamp_ns=0))
    assert isinstance(reach, SendReach)  # the old leg's reach, at once canceled:
    assert isinstance(step(Sent(True)), PollAction)
    assert isinstance(step(ActionState(False)), CancelAction)
    assert step() == Finish(Outcome.CANCELED, "stopped on the way")


# -- navigate's final heading --------------------------------------------------------------
def test_navigate_faces_the_goal_yaw_at_the_end() -> None:
    world = World(navigate(yaw=1.0), straight)
    assert world.run() == Finish(Outcome.SUCCEEDED, "reached")
    assert world.of(SendTurn) == [SendTurn(1.0)] and world.yaw == 1.0
    assert world.log.index(SendTurn(1.0)) > world.log.index(world.of(SendReach)[-1])


def test_a_failed_final_turn_is_a_flight_error_and_a_canceled_one_canceled() -> None:
    world = World(navigate(yaw=1.0), straight)
    world.fail = lambda command: "timeout" if isinstance(command, SendTurn) else None
    assert world.run() == Finish(Outcome.FLIGHT_ERROR, "final turn: timeout")
    step = Stepper(navigate(yaw=1.0))
    fly_leg(step, np.array([HERE, GOAL]))
    assert step(ActionState(True, True, "reached")) == SendTurn(1.0)
    step.cancel = True
    assert isinstance(step(Sent(True)), PollAction)
    assert isinstance(step(ActionState(False)), CancelAction)
    assert step() == Finish(Outcome.CANCELED, "final turn: canceled")


def test_a_goal_not_reached_is_not_turned_at() -> None:
    world = World(navigate(yaw=1.0), lambda s, g, w: failed("NoPathFound"))
    assert world.run().outcome is Outcome.NO_PATH and world.of(SendTurn) == []


# -- survey turns --------------------------------------------------------------------------
def test_survey_turns_a_quarter_each_then_reports_the_count() -> None:
    world = World(SurveyPolicy(4), straight)
    assert world.run() == Finish(Outcome.SUCCEEDED, "4 survey turns")
    assert world.of(SendTurn) == [SendTurn(math.pi / 2, relative=True)] * 4
    assert world.yaw == pytest.approx(2 * math.pi)


def test_a_failed_survey_turn_ends_the_survey_and_says_which() -> None:
    world = World(SurveyPolicy(4), straight)
    world.fail = lambda command: "timeout" if len(world.of(SendTurn)) == 2 else None
    assert world.run() == Finish(Outcome.FLIGHT_ERROR, "survey turn 2: timeout")
    assert len(world.of(SendTurn)) == 2
    step = Stepper(SurveyPolicy(1))
    assert isinstance(step(), SendTurn)
    assert step(Sent(False, "busy")) == Finish(Outcome.FLIGHT_ERROR,
                                               "survey turn 1: rejected: busy")
    step = Stepper(SurveyPolicy(1))
    step()
    step.cancel = True
    assert isinstance(step(Sent(True)), PollAction)
    assert isinstance(step(ActionState(False)), CancelAction)
    assert step() == Finish(Outcome.CANCELED, "survey turn 1: canceled")


def test_a_turn_still_running_is_polled_every_poll_period() -> None:
    step = Stepper(SurveyPolicy(1))
    step()
    assert isinstance(step(Sent(True)), PollAction)
    assert step(ActionState(False)) == Sleep(POLL_S)
    assert step() == PollAction()
    assert step(ActionState(True, True, "faced")) == Finish(Outcome.SUCCEEDED, "1 survey turns")


# -- exploring -----------------------------------------------------------------------------
AREA = np.array([[1.0, 1.0], [4.0, 1.0], [4.0, 2.5], [1.0, 2.5]])
FIELD = (np.array([0.0, 0.0, 0.0]), np.array([20.0, 14.0, 4.0]))


def explore(explore_tuning: ExploreTuning = EXPLORE, follow: FollowTuning = FOLLOW,
            **kwargs: Any) -> ExplorePolicy:
    return ExplorePolicy(follow, explore_tuning, area=kwargs.pop("area", AREA),
                         altitude=kwargs.pop("altitude", Z), field_min=FIELD[0],
                         field_max=FIELD[1], explore_paths=kwargs.pop("explore_paths", {}),
                         start_ns=kwargs.pop("start_ns", 0), **kwargs)


def lanes(here: np.ndarray = HERE, sweep: int = 0, area: np.ndarray = AREA) -> np.ndarray:
    return explore_waypoints(EXPLORE, {}, *FIELD, area, Z, here, sweep)[0]


def test_one_sweep_without_wanted_markers_flies_every_lane_end_and_covers_the_area() -> None:
    world = World(explore(), straight, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    expected = lanes(np.array([1.0, 1.0, Z]))
    assert end.outcome is Outcome.COVERED
    assert end.message == (f"{len(expected)}/{len(expected)} waypoints flown in 1 sweep "
                           "(last: coverage lanes over the area), 0 skipped without a path")
    assert [r.target.tolist() for r in world.of(SendReach)] == expected.tolist()
    assert {(r.radius, r.speed) for r in world.of(SendReach)} == {
        (FOLLOW.waypoint_radius, FOLLOW.cruise_speed)}
    assert end.coverage == 1.0 and end.markers_found == ()
    assert world.of(Log) == [Log(f"explore sweep 1/1: {len(expected)} waypoints "
                                 "(coverage lanes over the area)")]


def test_while_the_wanted_marker_is_unseen_it_sweeps_again_across_then_along() -> None:
    world = World(explore(wanted=frozenset({19})), straight, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.COVERED and "in 3 sweeps" in end.message
    assert "(last: coverage lanes over the area)" in end.message
    assert [log.text.split(":")[0] for log in world.of(Log)] == [
        "explore sweep 1/3", "explore sweep 2/3", "explore sweep 3/3"]
    assert "coverage lanes across the area" in world.of(Log)[1].text
    flown = len(world.of(SendReach))
    assert end.message.startswith(f"{flown}/{flown} waypoints")


def test_two_sweeps_are_counted_in_the_message() -> None:
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "explore_sweeps": 2})
    world = World(explore(tuning, wanted=frozenset({19})), straight,
                  here=np.array([1.0, 1.0, Z]))
    assert " in 2 sweeps (last: coverage lanes across the area)" in world.run().message


def test_lane_points_split_a_lane_evenly_at_most_the_spacing_apart() -> None:
    a, b = np.array([1.0, 9.0, Z]), np.array([19.0, 9.0, Z])
    points = lane_points(a, b, 4.0)
    assert points.shape == (4, 3)  # 18 m in 5 pieces of 3.6 m
    assert np.allclose(points[:, 0], [4.6, 8.2, 11.8, 15.4]) and np.all(points[:, 1:] == [9, Z])
    assert lane_points(a, b, 18.0).shape == (0, 3)  # one piece: no point between
    assert lane_points(a, a, 3.0).shape == (0, 3)


LONG_AREA = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 2.0], [1.0, 2.0]])


def test_a_lane_is_flown_through_its_points_passing_them_and_stopping_at_its_end() -> None:
    world = World(explore(area=LONG_AREA), straight, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.COVERED
    reaches = world.of(SendReach)
    # lane 1 west to east through x = 4 and 7, the crossing, lane 2 back through 7 and 4
    assert [r.target[:2].tolist() for r in reaches] == [
        [1, 1], [4, 1], [7, 1], [10, 1], [10, 2], [7, 2], [4, 2], [1, 2]]
    assert [r.stop_at_target for r in reaches] == [True, False, False, True, True, False,
                                                   False, True]
    assert end.message.startswith("4/4 waypoints flown")  # the lane ends are the waypoints


def test_a_detour_round_an_obstacle_in_a_lane_comes_back_to_the_lane() -> None:
    """The shortest path from the lane's start to its end would leave the lane for good;
    the lane's points bring it back. A point inside the obstacle is passed by at once."""
    inside = np.array([4.0, 1.0, Z])

    def wall_at_x4(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if np.allclose(goal, inside):
            return failed("GoalOccupied: in the wall")
        if start[0] < 4.0 < goal[0]:  # round the wall's north end, 3 m off the lane
            return ok(np.array([start, [4.0, 4.0, Z], goal]), stamp_ns=world.now_ns)
        return straight(start, goal, world)

    area = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 1.0], [1.0, 1.0]])
    world = World(explore(area=area), wall_at_x4, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.COVERED
    targets = [r.target[:2].tolist() for r in world.of(SendReach)]
    assert targets == [[1, 1], [4, 4], [7, 1], [10, 1]]  # back on the lane at x = 7
    goals = [c.goal[:2].tolist() for c in world.of(Plan)]
    assert goals.count([4.0, 1.0]) == 1  # the point in the wall: one plan, no retries
    assert Sleep(FOLLOW.replan_period_s) not in world.log


def test_a_lane_point_reached_only_far_round_an_obstacle_is_passed_by() -> None:
    """Past the far end of a wall across the whole lane: the point is the other sweep's."""
    def long_wall_at_x5(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if start[0] < 5.5 < goal[0]:  # round the wall's end, 6 m off the lane
            return ok(np.array([start, [5.5, 7.0, Z], goal]), stamp_ns=world.now_ns)
        return straight(start, goal, world)

    area = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 1.0], [1.0, 1.0]])
    world = World(explore(area=area), long_wall_at_x5, here=np.array([1.0, 1.0, Z]))
    world.run()
    targets = [r.target[:2].tolist() for r in world.of(SendReach)]
    assert targets[:2] == [[1, 1], [4, 1]]  # the lane's first point, this side of the wall
    # its second, (7, 1): 12.4 m round for 3 m straight, more than LANE_POINT_DETOUR_M more
    assert [7.0, 1.0] not in targets
    assert targets[-1] == [10.0, 1.0]  # the lane's end is flown to as before


@pytest.mark.parametrize(("via", "passed"), [
    ((4.0, 3.0), True),  # back onto the lane 34 deg off it: passed, turning on the way
    ((6.0, 3.0), False),  # 63 deg off: stopped there, to turn and face the lane first
])
def test_a_lane_point_after_a_detour_is_passed_only_if_the_lane_goes_on_its_way(
        via: tuple[float, float], passed: bool) -> None:
    def detour_to_x7(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if start[0] < via[0] - 1e-9 and np.allclose(goal, [7.0, 1.0, Z]):
            return ok(np.array([start, [*via, Z], goal]), stamp_ns=world.now_ns)
        return straight(start, goal, world)

    area = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 1.0], [1.0, 1.0]])
    world = World(explore(area=area), detour_to_x7, here=np.array([1.0, 1.0, Z]))
    world.run()
    at_x7 = [r for r in world.of(SendReach) if np.allclose(r.target, [7.0, 1.0, Z])]
    assert len(at_x7) == 1 and at_x7[0].stop_at_target is not passed


def wall_across_the_lane(wall_x: float, *, seen_at_s: float = 0.0
                         ) -> Callable[[np.ndarray, np.ndarray, World], Planned]:
    """A planner for a wall across the lane y = 1: its inflated cubes are x in [``wall_x``,
    ``wall_x`` + 1], y < 5, on the map from ``seen_at_s`` on. A goal in it fails; a
    straight line through it is flown round its north end."""
    def inside(point: np.ndarray) -> bool:
        return bool(wall_x <= point[0] <= wall_x + 1.0 and point[1] < 5.0)

    def plan(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if world.now_ns < seen_at_s * 1e9:
            return straight(start, goal, world)
        if inside(goal):
            return failed("GoalOccupied: in the wall")
        if not any(inside(start + (goal - start) * f) for f in np.linspace(0.0, 1.0, 101)):
            return straight(start, goal, world)
        north = [[min(start[0], wall_x - 0.1), 5.5, Z]] if start[1] < 5.0 else []
        return ok(np.array([start, *north, [wall_x + 1.1, 5.5, Z], goal]),
                  stamp_ns=world.now_ns)
    return plan


ONE_LANE = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 1.0], [1.0, 1.0]])


@pytest.mark.parametrize(("wall_x", "pass_stop_s", "passed"), [
    (4.45, 0.5, False),  # 0.45 m of room past (4, 1), 0.5 m needed to stop from 1 m/s
    (4.55, 0.5, True),  # 0.55 m of room
    (4.45, 0.4, True),  # a vehicle that stops in 0.4 s from 1 m/s
])
def test_a_lane_point_is_passed_at_speed_only_with_room_to_stop_past_it(
        wall_x: float, pass_stop_s: float, passed: bool) -> None:
    """A wall across the lane beyond its point (4, 1): a lane point passed at speed is
    stopped past, not at; random arena 149's arms hit such a wall."""
    follow = FollowTuning(**{**FOLLOW.__dict__, "pass_stop_s": pass_stop_s})
    world = World(explore(area=ONE_LANE, follow=follow), wall_across_the_lane(wall_x),
                  here=np.array([1.0, 1.0, Z]))
    world.run()
    at_x4 = [r for r in world.of(SendReach) if np.allclose(r.target, [4.0, 1.0, Z])]
    assert len(at_x4) == 1 and at_x4[0].stop_at_target is not passed
    room = FOLLOW.cruise_speed * pass_stop_s  # the way on is planned that far
    assert any(np.allclose(c.start, [4.0, 1.0, Z]) and np.allclose(c.goal, [4.0 + room, 1, Z])
               for c in world.of(Plan))


@pytest.mark.parametrize("speed", [0.5, 1.5, 2.5])
@pytest.mark.parametrize(("margin", "passed"), [
    (-0.05, False),  # the wall 5 cm short of the room to stop from that speed
    (0.05, True),  # 5 cm beyond it
])
def test_the_room_to_stop_past_a_lane_point_grows_with_the_speed(
        speed: float, margin: float, passed: bool) -> None:
    """At a cruise speed other than 1 m/s the room asked for past (4, 1) is speed *
    pass_stop_s (0.25, 0.75, 1.25 m at 0.5 s): a wall just inside it makes the point a
    stop, one just beyond lets the vehicle pass it at speed."""
    follow = FollowTuning(**{**FOLLOW.__dict__, "cruise_speed": speed})
    room = speed * follow.pass_stop_s
    world = World(explore(area=ONE_LANE, follow=follow),
                  wall_across_the_lane(4.0 + room + margin), here=np.array([1.0, 1.0, Z]))
    world.run()
    at_x4 = [r for r in world.of(SendReach) if np.allclose(r.target, [4.0, 1.0, Z])]
    assert len(at_x4) == 1 and at_x4[0].speed == speed
    assert at_x4[0].stop_at_target is not passed, (
        f"at {speed} m/s with the wall {room + margin:.2f} m past the point")
    assert any(np.allclose(c.start, [4.0, 1.0, Z]) and np.allclose(c.goal, [4.0 + room, 1, Z])
               for c in world.of(Plan)), "the way on was not planned for the speed's room"


def test_a_wall_mapped_past_a_lane_point_on_the_way_to_it_turns_the_pass_into_a_stop() -> None:
    """The check is asked again at each re-plan: a newer reach brakes to the point."""
    world = World(explore(area=ONE_LANE), wall_across_the_lane(4.45, seen_at_s=5.0),
                  here=np.array([1.0, 1.0, Z]), polls=40)  # (4, 1) sent at 3.9 s, re-planned
    # at 4.9 s (the wall not yet seen) and 5.9 s (seen)
    world.run()
    at_x4 = [r.stop_at_target for r in world.of(SendReach)
             if np.allclose(r.target, [4.0, 1.0, Z])]
    assert at_x4 == [False, True]


def test_the_room_to_stop_is_looked_for_along_the_way_the_point_is_reached() -> None:
    """Back onto the lane at (7, 1) from a detour, heading south-east: the vehicle carries
    on that way, not along the lane, when it stops past the point."""
    def detour_to_x7(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if start[0] < 5.0 and np.allclose(goal, [7.0, 1.0, Z]):  # arrives 27 deg off the lane
            return ok(np.array([start, [5.0, 2.0, Z], goal]), stamp_ns=world.now_ns)
        if goal[1] < 0.8 and goal[0] > 7.0:  # a block south-east of (7, 1)
            return failed("GoalOccupied: in the block")
        return straight(start, goal, world)

    world = World(explore(area=ONE_LANE), detour_to_x7, here=np.array([1.0, 1.0, Z]))
    world.run()
    at_x7 = [r for r in world.of(SendReach) if np.allclose(r.target, [7.0, 1.0, Z])]
    assert len(at_x7) == 1 and at_x7[0].stop_at_target
    room = 0.5 * np.array([2.0, -1.0, 0.0]) / math.sqrt(5.0)
    assert any(np.allclose(c.start, [7.0, 1.0, Z]) and np.allclose(c.goal, [7.0, 1.0, Z] + room)
               for c in world.of(Plan))


def test_the_points_behind_a_lane_start_replaced_further_on_are_not_flown_back_to() -> None:
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "replace_blocked_lane_ends": True})

    def block_west_of_x4_2(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if goal[0] < 4.2:
            return failed("GoalOccupied: in the block")
        return straight(start, goal, world)

    area = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 1.0], [1.0, 1.0]])
    world = World(explore(tuning, area=area), block_west_of_x4_2, here=np.array([2.0, 3.0, Z]))
    end = world.run()
    # the lane's start (1, 1) is replaced by (4.5, 1); its point (4, 1) is behind it
    assert [r.target[:2].tolist() for r in world.of(SendReach)] == [[4.5, 1], [7, 1], [10, 1]]
    assert end.message.startswith("2/2 waypoints flown")


def test_a_wanted_marker_seen_on_the_way_to_a_lane_point_ends_the_exploration() -> None:
    def marker_on_the_way_to_the_first_point(world: World) -> None:
        flying = world.flying
        if isinstance(flying, SendReach) and flying.target[0] == 4.0 and world.polled >= 2:
            world.markers = {19: world.now_ns}

    world = World(explore(area=LONG_AREA, wanted=frozenset({19})), straight, polls=10,
                  during=marker_on_the_way_to_the_first_point, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.MARKER_FOUND
    reaches = world.of(SendReach)
    assert reaches[1].target[:2].tolist() == [4, 1] and not reaches[1].stop_at_target
    assert reaches[-1].stop_at_target and reaches[-1].radius == FOLLOW.goal_radius  # held
    assert len(reaches) == 3  # the lane's start, its first point, the hold


def test_a_failed_reach_to_a_lane_point_is_reported_with_the_point() -> None:
    world = World(explore(area=LONG_AREA), straight, here=np.array([1.0, 1.0, Z]))
    world.fail = lambda c: "motors off" if (isinstance(c, SendReach)
                                            and c.target[0] == 4.0) else None
    end = world.run()
    assert end.outcome is Outcome.FLIGHT_ERROR
    assert end.message.startswith("sweep 1, the point (4.00, 1.00) m of the lane to "
                                  "waypoint 2: reach failed")


def test_a_wanted_marker_seen_on_the_way_stops_the_leg_and_holds() -> None:
    def marker_after_3_s(world: World) -> None:
        if world.now_ns >= 3_000_000_000:
            world.markers = {12: world.now_ns, 19: world.now_ns}

    world = World(explore(wanted=frozenset({14, 19})), straight, polls=50,
                  during=marker_after_3_s, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.MARKER_FOUND
    assert end.message == "marker 19 found (coverage lanes over the area)"
    assert end.markers_found == (12, 19)
    hold = world.of(SendReach)[-1]
    assert isinstance(world.log[world.log.index(hold) - 1], CancelAction)  # the leg, on the way
    assert world.times[world.log.index(hold)] == 3_000_000_000
    assert CancelAction() not in world.log[world.log.index(hold):]  # held to the end
    assert hold.radius == FOLLOW.goal_radius and hold.stop_at_target
    assert np.array_equal(hold.target, world.position)
    assert 0.0 < end.coverage < 1.0


def test_markers_seen_before_the_start_do_not_count() -> None:
    world = World(explore(wanted=frozenset({19}), start_ns=5), straight,
                  here=np.array([1.0, 1.0, Z]))
    world.markers = {19: 4, 12: 5}
    end = world.run()
    assert end.outcome is Outcome.COVERED and end.markers_found == (12,)


def test_a_stop_on_the_way_is_final_even_if_the_marker_turns_out_older_than_the_start(
        ) -> None:
    """A detection captured before the start may arrive late and replace the marker's
    stamp: exploring still ends where it stopped (no other sweep)."""
    def marker_then_an_older_capture(world: World) -> None:
        if world.now_ns >= 3_000_000_000 and 19 not in world.markers:
            world.markers = {19: world.now_ns}
        elif CancelAction() in world.log:
            world.markers = {19: -1}

    world = World(explore(wanted=frozenset({19})), straight, polls=50,
                  during=marker_then_an_older_capture, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert len(world.of(Log)) == 1 and end.outcome is Outcome.COVERED
    assert world.log.count(CancelAction()) == 1


def test_a_marker_seen_between_legs_stops_before_the_next_one() -> None:
    world = World(explore(wanted=frozenset({19})), straight, here=np.array([1.0, 1.0, Z]))
    world.fail = lambda command: world.markers.update({19: world.now_ns})  # type: ignore[func-returns-value]
    end = world.run()
    assert end.outcome is Outcome.MARKER_FOUND
    assert len(world.of(SendReach)) == 2  # the first lane end, then the hold


def test_the_time_budget_stops_exploring_and_holds() -> None:
    world = World(explore(wanted=frozenset({19}), budget_ns=2_000_000_000), straight,
                  polls=10, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end == ExploreFinish(Outcome.TIME_BUDGET, "time budget used up", end.coverage, ())
    hold = world.of(SendReach)[-1]
    assert hold.stop_at_target and world.times[world.log.index(hold)] == 2_000_000_000


def test_the_time_budget_counts_from_the_start() -> None:
    world = World(explore(wanted=frozenset({19}), budget_ns=2_000_000_000,
                          start_ns=1_000_000_000), straight, polls=10,
                  here=np.array([1.0, 1.0, Z]))
    world.now_ns = 1_000_000_000
    assert world.run().outcome is Outcome.TIME_BUDGET
    hold = world.of(SendReach)[-1]
    assert world.times[world.log.index(hold)] == 3_000_000_000


def test_a_budget_used_up_by_the_last_lane_of_a_sweep_ends_the_sweeps() -> None:
    n = len(lanes(np.array([1.0, 1.0, Z])))

    def a_second_per_lane_end(world: World) -> None:  # reaches take no time otherwise
        world.now_ns = world.reached * 1_000_000_000

    world = World(explore(wanted=frozenset({19}), budget_ns=n * 1_000_000_000), straight,
                  polls=1, during=a_second_per_lane_end, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.TIME_BUDGET and len(world.of(Log)) == 1
    assert world.reached == n + 1  # the lane ends and the hold


def test_waypoints_with_no_path_are_skipped() -> None:
    here = np.array([1.0, 1.0, Z])
    expected = lanes(here)
    world = World(explore(), lambda s, g, w: failed() if g[0] == 4.0
                  else ok(np.array([s, g])), here=here)
    end = world.run()
    n = len(expected)
    assert end.message.startswith(f"{n - 3}/{n} waypoints flown")  # 3 lane ends at x = 4 m
    assert end.message.endswith("3 skipped without a path")


def test_a_lane_end_with_no_path_is_replaced_by_the_nearest_reachable_point_on_the_lane(
        ) -> None:
    here = np.array([1.0, 1.0, Z])
    expected = lanes(here)
    end_x = expected[1][0]  # the first lane's far end, in a block 1.2 m deep
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "replace_blocked_lane_ends": True})

    def planner(start: np.ndarray, goal: np.ndarray, _w: World) -> Planned:
        return failed() if goal[0] > end_x - 1.2 else ok(np.array([start, goal]))

    world = World(explore(tuning), planner, here=here)
    end = world.run()
    assert "0 skipped" in end.message
    targets = [r.target for r in world.of(SendReach)]
    replacement = world.of(SendReach)[1]
    assert (replacement.radius, replacement.speed) == (FOLLOW.waypoint_radius,
                                                       FOLLOW.cruise_speed)
    assert np.allclose(targets[1], expected[1] + (expected[0] - expected[1])
                       * (1.5 / np.linalg.norm(expected[0] - expected[1])))
    # tried toward the lane's other end, LANE_STEP_M after LANE_STEP_M, then flown
    tries = [c.goal[0] for c in world.of(Plan) if c.goal[1] == expected[1][1]]
    assert tries == [1.0] + [4.0] * FOLLOW.plan_attempts + [
        4.0 - LANE_STEP_M, 4.0 - 2 * LANE_STEP_M, 4.0 - 3 * LANE_STEP_M, 4.0 - 3 * LANE_STEP_M]


def test_a_replacement_reached_only_by_a_long_detour_is_not_taken() -> None:
    here = np.array([1.0, 1.0, Z])
    expected = lanes(here)
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "replace_blocked_lane_ends": True})

    def planner(start: np.ndarray, goal: np.ndarray, _w: World) -> Planned:
        if np.array_equal(goal, expected[1]):
            return failed()
        if (goal[1] == expected[1][1] and np.array_equal(start, expected[0])
                and not np.array_equal(goal, start)):
            # reached only round the far side: 3 times the straight line
            mid = (start + goal) / 2 + (0.0, np.linalg.norm(goal - start), 0.0)
            return ok(np.array([start, mid, goal]))
        return ok(np.array([start, goal]))

    world = World(explore(tuning), planner, here=here)
    end = world.run()
    assert "1 skipped" in end.message


def test_a_replacement_within_the_detour_allowance_is_taken() -> None:
    here = np.array([1.0, 1.0, Z])
    expected = lanes(here)
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "replace_blocked_lane_ends": True})

    def planner(start: np.ndarray, goal: np.ndarray, _w: World) -> Planned:
        if np.array_equal(goal, expected[1]):
            return failed()
        if (goal[1] == expected[1][1] and np.array_equal(start, expected[0])
                and not np.array_equal(goal, start)):
            # exactly LANE_DETOUR times the straight line plus a step
            straight_m = float(np.linalg.norm(goal - start))
            long = 1.2 * straight_m + LANE_STEP_M
            bulge = math.sqrt((long / 2) ** 2 - (straight_m / 2) ** 2)
            return ok(np.array([start, (start + goal) / 2 + (0.0, bulge, 0.0), goal]))
        return ok(np.array([start, goal]))

    world = World(explore(tuning), planner, here=here)
    assert "0 skipped" in world.run().message


def test_a_predefined_path_end_with_no_path_is_replaced_toward_the_previous_waypoint(
        ) -> None:
    path_xy = np.array([[1.0, 1.0], [6.0, 1.0], [6.0, 3.0]])
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "replace_blocked_lane_ends": True,
                              "arena": "a", "start_pad": 2})

    def planner(start: np.ndarray, goal: np.ndarray, _w: World) -> Planned:
        return failed() if goal[0] > 5.0 and goal[1] < 2.0 else ok(np.array([start, goal]))

    world = World(explore(tuning, area=np.empty((0, 2)), explore_paths={"a": {2: path_xy}}),
                  planner, here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert "explore path of a pad 2" in end.message and "0 skipped" in end.message
    assert world.of(SendReach)[1].target.tolist() == [5.0, 1.0, Z]


def test_a_first_waypoint_with_no_path_and_no_previous_one_is_skipped() -> None:
    path_xy = np.array([[6.0, 1.0], [6.0, 3.0]])
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "replace_blocked_lane_ends": True,
                              "arena": "a", "start_pad": 2})
    world = World(explore(tuning, area=np.empty((0, 2)), explore_paths={"a": {2: path_xy}}),
                  lambda s, g, w: failed() if g[1] < 2.0 else ok(np.array([s, g])),
                  here=np.array([1.0, 1.0, Z]))
    assert world.run().message.startswith("1/2 waypoints flown")


def test_a_flight_error_ends_exploring_and_names_the_sweep_and_waypoint() -> None:
    world = World(explore(wanted=frozenset({19})), straight, here=np.array([1.0, 1.0, Z]))
    world.fail = lambda command: "lost offboard" if len(world.of(SendReach)) >= 3 else None
    end = world.run()
    assert end.outcome is Outcome.FLIGHT_ERROR
    assert end.message == "sweep 1, waypoint 3: reach failed: lost offboard"
    assert len(world.of(Log)) == 1  # no other sweep
    assert world.of(SendReach)[-1].target.tolist() != world.position.tolist()


def test_cancel_ends_exploring_canceled_without_holding() -> None:
    def cancel_after_1_s(world: World) -> None:
        world.cancel = world.now_ns >= 1_000_000_000

    world = World(explore(), straight, polls=30, during=cancel_after_1_s,
                  here=np.array([1.0, 1.0, Z]))
    end = world.run()
    assert end.outcome is Outcome.CANCELED and end.message == "canceled"
    assert len(world.of(SendReach)) == 1


# -- an explore goal after an interrupted one (the mission's HOLD, then RESUME) -----------
#: 5 lanes along x (y = 1 to 6, 1.25 m apart at most), 9 m long: points at x = 4 and 7
WIDE_AREA = np.array([[1.0, 1.0], [10.0, 1.0], [10.0, 6.0], [1.0, 6.0]])
CORNER = np.array([1.0, 1.0, Z])


def cancel_once_flying_to(target: np.ndarray) -> Callable[[World], None]:
    """Cancel the goal as soon as a reach to ``target`` has been sent (the vehicle then
    stops a fifth of the way along that leg)."""
    def during(world: World) -> None:
        world.cancel = any(np.allclose(r.target, target) for r in world.of(SendReach))
    return during


def interrupted(target: np.ndarray, **kwargs: Any) -> tuple[World, ExploreSoFar]:
    """An explore of ``WIDE_AREA`` from its corner canceled on the way to ``target``, and
    how far it got."""
    world = World(explore(area=WIDE_AREA, **kwargs), straight, here=CORNER,
                  during=cancel_once_flying_to(target))
    assert world.run().outcome is Outcome.CANCELED
    so_far = world.policy.so_far()
    assert so_far is not None
    return world, so_far


def resumed(before: World, so_far: ExploreSoFar, **kwargs: Any) -> World:
    """The next goal, from where ``before`` left the vehicle, handed ``so_far``."""
    area = kwargs.pop("area", WIDE_AREA)
    return World(explore(area=area, so_far=so_far, **kwargs), straight,
                 here=before.position)


def targets(world: World) -> list[list[float]]:
    return [r.target.tolist() for r in world.of(SendReach)]


def test_an_explore_after_a_canceled_one_flies_only_the_legs_not_yet_flown() -> None:
    waypoints = lanes(CORNER, area=WIDE_AREA)
    assert len(waypoints) == 10  # 5 lanes
    before, so_far = interrupted(waypoints[4])  # on the crossing to the third lane
    assert (so_far.sweep, so_far.next_leg, so_far.flown) == (0, 4, 4)
    whole = World(explore(area=WIDE_AREA), straight, here=CORNER)
    whole_end = whole.run()
    after = resumed(before, so_far)
    end = after.run()
    # the third lane's start first (planned from where the vehicle stopped), then the rest
    # as an uninterrupted explore flies it: no reach of the first two lanes again
    first_plan = after.of(Plan)[0]
    assert np.array_equal(first_plan.start, before.position)
    assert np.array_equal(first_plan.goal, waypoints[4])
    left = targets(whole)[targets(whole).index(waypoints[4].tolist()):]
    assert targets(after) == left
    assert after.of(Log)[0] == Log("explore sweep 1/1: 10 waypoints (coverage lanes over the "
                                   "area), resumed at waypoint 5 after an interruption")
    # the waypoints flown before count, and so does what the camera saw of the area
    assert end.outcome is Outcome.COVERED and end.message == whole_end.message
    assert end.message.startswith("10/10 waypoints flown")
    first = after.of(ExploreProgress)[0]
    fresh = World(explore(area=WIDE_AREA), straight, here=before.position)
    fresh.run()
    assert first.coverage >= float(so_far.seen.mean()) > fresh.of(ExploreProgress)[0].coverage
    assert end.coverage == whole_end.coverage


def test_a_lane_interrupted_half_flown_goes_on_from_where_the_vehicle_is() -> None:
    waypoints = lanes(CORNER, area=WIDE_AREA)
    lane_start, lane_end = waypoints[2], waypoints[3]  # the second lane, east to west
    points = lane_points(lane_start, lane_end, EXPLORE.lane_point_spacing)
    before, so_far = interrupted(points[1])  # between its first and second point
    assert so_far.next_leg == 3
    after = resumed(before, so_far)
    assert after.run().outcome is Outcome.COVERED
    assert targets(after)[:2] == [points[1].tolist(), lane_end.tolist()]
    reached_before = {tuple(t) for t in targets(before)[:-1]}  # the last one was canceled
    assert not reached_before & {tuple(t) for t in targets(after)}  # nothing twice


def test_an_explore_interrupted_in_a_later_sweep_goes_on_in_that_sweep() -> None:
    wanted = frozenset({19})
    whole = World(explore(area=WIDE_AREA, wanted=wanted), straight, here=CORNER)
    whole.run()
    second_sweep = int(np.flatnonzero(["sweep 2/3" in log.text for log in whole.of(Log)])[0])
    assert second_sweep == 1
    at = whole.log.index(whole.of(Log)[1])  # the reaches after the second sweep's log
    across = [c for c in whole.log[at:] if isinstance(c, SendReach)]
    before, so_far = interrupted(across[3].target, wanted=wanted)
    assert so_far.sweep == 1
    after = resumed(before, so_far, wanted=wanted)
    end = after.run()
    assert after.of(Log)[0].text.startswith("explore sweep 2/3")
    assert [log.text.split(":")[0] for log in after.of(Log)] == [
        "explore sweep 2/3", "explore sweep 3/3"]
    assert end.outcome is Outcome.COVERED and "in 3 sweeps" in end.message
    assert end.message == whole.of(Finish)[0].message  # the same count as in one goal


def test_an_explore_ended_by_a_flight_error_is_gone_on_from_too() -> None:
    """The fault that holds the mission (a VIO drop) can make flight control refuse or fail
    the next reach before the mission's cancel comes: the goal ends with a flight error,
    and the goal the RESUME sends goes on from the leg that failed."""
    waypoints = lanes(CORNER, area=WIDE_AREA)
    before = World(explore(area=WIDE_AREA), straight, here=CORNER)
    before.fail = lambda c: ("no valid position estimate" if isinstance(c, SendReach)
                             and np.allclose(c.target, waypoints[4]) else None)
    assert before.run().outcome is Outcome.FLIGHT_ERROR
    assert Outcome.FLIGHT_ERROR in EXPLORE_INTERRUPTED
    so_far = before.policy.so_far()
    assert so_far is not None and (so_far.next_leg, so_far.flown) == (4, 4)
    after = resumed(before, so_far)
    assert after.run().message.startswith("10/10 waypoints flown")
    assert targets(after)[0] == waypoints[4].tolist()


@pytest.mark.parametrize("ended", ["covered", "marker", "budget"])
def test_an_explore_that_ended_leaves_nothing_to_go_on_from(ended: str) -> None:
    """Found, covered or out of time, the exploration is over: a next goal starts afresh."""
    wanted = frozenset({19}) if ended == "marker" else frozenset()
    policy = explore(area=WIDE_AREA, wanted=wanted, budget_ns=int(5e9) if ended == "budget"
                     else 0)
    world = World(policy, straight, here=CORNER)
    if ended == "marker":
        world.markers = {19: 0}
    end = world.run()
    assert end.outcome not in EXPLORE_INTERRUPTED
    assert policy.so_far() is None


@pytest.mark.parametrize("other", [{"area": LONG_AREA}, {"wanted": frozenset({19})},
                                   {"altitude": Z + 0.4}])
def test_a_goal_for_another_area_altitude_or_markers_starts_afresh(other: dict[str, Any]
                                                                   ) -> None:
    waypoints = lanes(CORNER, area=WIDE_AREA)
    before, so_far = interrupted(waypoints[4])
    after = resumed(before, so_far, **other)
    assert after.policy.resumed is None
    fresh = World(explore(**{"area": WIDE_AREA, **other}), straight, here=before.position)
    fresh.run()
    after.run()
    assert after.of(Log)[0] == Log("explore from the start: the goal interrupted last was "
                                   "for another area, altitude or markers")
    assert targets(after) == targets(fresh)
    assert after.of(ExploreProgress)[0].coverage == fresh.of(ExploreProgress)[0].coverage


def test_an_explore_not_yet_started_has_nothing_to_go_on_from() -> None:
    assert explore().so_far() is None


def test_explore_progress_names_the_waypoint_the_coverage_and_the_markers() -> None:
    world = World(explore(), straight, here=np.array([1.0, 1.0, Z]))
    world.markers = {7: 1}
    world.run()
    progress = world.of(ExploreProgress)
    first = lanes(np.array([1.0, 1.0, Z]))[0]
    assert progress and np.array_equal(progress[0].waypoint, first)
    assert all(pr.markers_found == (7,) for pr in progress)
    coverage = [pr.coverage for pr in progress]
    assert coverage == sorted(coverage) and 0.0 < coverage[0] < coverage[-1]


def seen_from(height: float, altitude: float = Z, corner: tuple[float, float] = (1.0, 1.0)
              ) -> float:
    """The coverage after the first stop check, from ``height`` at the area's ``corner``."""
    paths = {"a": {2: np.array([[3.0, 2.0]])}}
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "arena": "a", "start_pad": 2})
    policy = ExplorePolicy(FOLLOW, tuning, area=np.empty((0, 2)), altitude=altitude,
                           field_min=np.array([1.0, 1.0, 0.0]),
                           field_max=np.array([4.0, 2.5, 4.0]),
                           explore_paths=paths, start_ns=0)
    step = Stepper(policy, here=np.array([*corner, height]))
    assert isinstance(step(), Log)
    assert isinstance(step(), Plan)
    return policy.grid.fraction


def test_the_footprint_seen_grows_with_the_height_flown() -> None:
    # at the explore altitude the footprint is 1.73 m along the heading (east) by 2.31 m
    # across (60 deg, 4:3), centred on the corner: the quarter of it in the area is
    # 0.866 m x 1.155 m, which holds the centres of 3 x 5 of its 12 x 6 cells of 0.25 m
    assert seen_from(Z) == pytest.approx(15 / 72)
    assert seen_from(Z / 2) == pytest.approx(4 / 72)  # half the size: 2 x 2 cells
    # the footprint is the one from the height flown, whatever the altitude asked
    assert seen_from(Z, altitude=2 * Z) == pytest.approx(15 / 72)


def test_the_footprint_from_a_low_altitude_scales_too() -> None:
    assert seen_from(0.4, altitude=0.8) == pytest.approx(seen_from(0.4))


def test_an_explore_at_zero_altitude_sees_only_the_cell_under_it() -> None:
    assert seen_from(0.0, altitude=0.0) == 0.0
    assert seen_from(0.0, altitude=0.0, corner=(1.125, 1.125)) == 1 / 72  # a cell's centre


# -- the explore path ----------------------------------------------------------------------
def test_explore_waypoints_lanes_span_the_area_at_the_altitude_from_the_nearest_corner(
        ) -> None:
    points = lanes(np.array([4.0, 2.5, Z]))
    assert np.all(points[:, 2] == Z)
    assert points[0, :2].tolist() == [4.0, 2.5]
    assert points[:, :2].min(axis=0).tolist() == [1.0, 1.0]
    spacing = lane_spacing(Z, 60.0, 4.0 / 3.0, 0.2)
    ys = np.unique(points[:, 1])
    assert np.max(np.diff(ys)) <= spacing + 1e-9


def test_explore_waypoints_over_the_field_keep_off_the_walls() -> None:
    points, source = explore_waypoints(EXPLORE, {}, *FIELD, np.empty((0, 2)), Z, HERE)
    assert source == "coverage lanes over the field"
    assert points[:, 0].min() == 1.0 and points[:, 0].max() == 19.0
    assert points[:, 1].min() == 1.0 and points[:, 1].max() == 13.0
    far, _ = explore_waypoints(EXPLORE, {}, *FIELD, np.empty((0, 2)), Z,
                               np.array([20.0, 14.0, Z]))
    assert far[0, :2].tolist() == [19.0, 13.0]  # from the corner nearest the vehicle
    for sweep in (1, 3):
        across, source = explore_waypoints(EXPLORE, {}, *FIELD, np.empty((0, 2)), Z, HERE,
                                           sweep=sweep)
        assert source == "coverage lanes across the field"
        assert np.allclose(np.diff(across[:, 0])[::2], 0.0)  # lanes along y, the short side


def test_explore_waypoints_across_an_area_run_along_its_short_side() -> None:
    across, source = explore_waypoints(EXPLORE, {}, *FIELD, AREA, Z, HERE, sweep=1)
    assert source == "coverage lanes across the area"
    assert np.allclose(np.diff(across[:, 0])[::2], 0.0)
    along, _ = explore_waypoints(EXPLORE, {}, *FIELD, AREA, Z, HERE, sweep=2)
    assert np.allclose(np.diff(along[:, 1])[::2], 0.0)


def test_an_explore_of_the_field_flies_lanes_inside_its_walls() -> None:
    here = np.array([1.0, 1.0, Z])
    step = Stepper(explore(area=np.empty((0, 2))), here=here)
    expected, _ = explore_waypoints(EXPLORE, {}, *FIELD, np.empty((0, 2)), Z, here)
    assert step() == Log(f"explore sweep 1/1: {len(expected)} waypoints (coverage lanes over "
                         "the field)")
    first = step()
    assert isinstance(first, Plan) and np.array_equal(first.goal, expected[0])


def test_explore_waypoints_take_the_predefined_path_on_the_first_sweep_only() -> None:
    tuning = ExploreTuning(**{**EXPLORE.__dict__, "arena": "a", "start_pad": 2})
    paths = {"a": {2: np.array([[3.0, 3.0], [5.0, 3.0]])}}
    points, source = explore_waypoints(tuning, paths, *FIELD, np.empty((0, 2)), Z, HERE)
    assert source == "explore path of a pad 2" and points.tolist() == [[3, 3, Z], [5, 3, Z]]
    _, source = explore_waypoints(tuning, paths, *FIELD, np.empty((0, 2)), Z, HERE, sweep=1)
    assert source == "coverage lanes over the field"  # the lanes along first: fewest ends
    _, source = explore_waypoints(tuning, paths, *FIELD, np.empty((0, 2)), Z, HERE, sweep=2)
    assert source == "coverage lanes across the field"
    other = ExploreTuning(**{**EXPLORE.__dict__, "arena": "a", "start_pad": 3})
    _, source = explore_waypoints(other, paths, *FIELD, np.empty((0, 2)), Z, HERE)
    assert source == "coverage lanes over the field"


def test_the_tunings_take_their_values_from_the_navigator_parameters() -> None:
    values = {name: i for i, name in enumerate(NavigatorParams.__dataclass_fields__)}
    params = NavigatorParams(**values)  # type: ignore[arg-type]
    follow, tuning = FollowTuning.of(params), ExploreTuning.of(params)
    assert follow.plan_attempts == values["plan_attempts"]
    assert follow.max_reach_failures == values["max_reach_failures"]
    assert tuning.start_pad == values["start_pad"] and tuning.arena == values["arena"]


def test_a_recheck_that_plans_a_single_point_path_ends_the_path_without_an_error() -> None:
    """A leg re-checked from a point in the goal's own voxel gets a path of one point (the
    vehicle is there); it used to index past its end (random arena 200, light: the
    exploration failed with an IndexError and the robot was never found)."""
    old = p((0, 0), (2, 0), (4, 0))

    def planner(start: np.ndarray, goal: np.ndarray, world: World) -> Planned:
        if len(world.of(Plan)) == 1:
            return ok(old)
        if len(world.of(Plan)) == 2:  # the re-check from (2, 0): one point
            return ok(np.array([start]), stamp_ns=world.now_ns)
        return straight(start, goal, world)

    world = World(navigate(), planner)
    finish = world.run()
    assert finish.outcome is not Outcome.STOPPED
    assert world.of(SendReach)[0].target.tolist() == [2, 0, Z]
