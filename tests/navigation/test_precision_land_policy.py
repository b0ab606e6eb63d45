"""navigation/precision_land_policy.py: the landing goal's decisions, walked tick by tick
without the runtime or the simulator. A small test world moves the vehicle to each
commanded position at once and measures the pad's marker as the scanner would (body-frame
offset, height above it)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

from flight_control.policy import Finish, Outcome
from navigation.precision_land_policy import (
    TAKEOFF_MARGIN,
    CheckLeg,
    Move,
    PlanAnswer,
    PrecisionLandPolicy,
    Touchdown,
    goal_problem,
    pad_marker,
    search_rings,
)
from navigation.precision_landing import (
    LandingParams,
    LandingStrategy,
    Measurement,
    Phase,
    Pose,
    Wait,
)

PAD_ID = 7
PAD = (5.0, 3.0, 0.0)
P = LandingParams()
FRAME_NS = 83_333_333  # 12 Hz camera
S = 1_000_000_000


Planner = Callable[[CheckLeg], tuple[PlanAnswer, np.ndarray | None]]


def no_path_finder(check: CheckLeg) -> tuple[PlanAnswer, np.ndarray | None]:
    """No path finder on the graph: the map says nothing of any leg."""
    return PlanAnswer.UNKNOWN, None


@dataclass
class _World:
    """The vehicle (position, yaw) and the pad; ``visible`` False hides the marker;
    ``planner`` answers the search's leg checks, as the node does."""

    position: tuple[float, float, float]
    yaw: float = 0.5
    visible: bool = True
    now_ns: int = 0
    planner: Planner = no_path_finder
    checks: int = 0  # leg checks answered

    def marker(self) -> Measurement | None:
        if not self.visible:
            return None
        dx, dy = PAD[0] - self.position[0], PAD[1] - self.position[1]
        c, s = math.cos(self.yaw), math.sin(self.yaw)  # map -> body: rotate by -yaw
        return Measurement((c * dx + s * dy, -s * dx + c * dy), self.position[2] - PAD[2])

    def pose(self) -> Pose:
        return Pose(self.position, self.yaw)

    def frame(self, policy: PrecisionLandPolicy, dt_ns: int = FRAME_NS):
        self.now_ns += dt_ns
        command = policy.frame(self.now_ns, self.marker(), self.pose(), self.position, 0.0)
        while isinstance(command, CheckLeg):
            self.checks += 1
            command = policy.leg_planned(command, *self.planner(command), self.now_ns)
        return command

    def fly(self, policy: PrecisionLandPolicy, move: Move) -> None:
        """The move is flown and ends well."""
        self.position = move.position
        assert policy.reach_ended(True, False, "") == Wait()


def _policy(world: _World, strategy=LandingStrategy.CAPTURE, *, search_radius=0.0,
            **params) -> PrecisionLandPolicy:
    return PrecisionLandPolicy(LandingParams(**params), strategy, PAD_ID, PAD, world.pose(),
                               world.now_ns, search_radius=search_radius)


def _until_command(world: _World, policy: PrecisionLandPolicy, frames: int = 10):
    """Frames until the policy answers with something other than Wait."""
    for _ in range(frames):
        command = world.frame(policy)
        if not isinstance(command, Wait):
            return command
    raise AssertionError(f"only Wait for {frames} frames")


# -- goals ---------------------------------------------------------------------------------
def test_a_goal_within_reach_and_above_the_pad_is_accepted():
    assert goal_problem(PAD_ID, PAD, (4.0, 3.0, 1.5), max_pad_distance=5.0,
                        min_altitude=0.8) is None


def test_a_pad_position_that_is_not_finite_is_refused():
    problem = goal_problem(PAD_ID, (math.nan, 3.0, 0.0), (4.0, 3.0, 1.5),
                           max_pad_distance=0.0, min_altitude=0.8)
    assert problem is not None and "not finite" in problem
    assert goal_problem(PAD_ID, (5.0, 3.0, math.inf), (4.0, 3.0, 1.5), max_pad_distance=0.0,
                        min_altitude=0.8) is not None


def test_a_pad_farther_than_max_pad_distance_is_refused_with_the_distance():
    vehicle = (2.0, -1.0, 1.5)  # 5 m from the pad (3-4-5)
    assert goal_problem(PAD_ID, PAD, vehicle, max_pad_distance=5.0, min_altitude=0.8) is None
    problem = goal_problem(PAD_ID, PAD, vehicle, max_pad_distance=4.99, min_altitude=0.8)
    assert problem == f"pad {PAD_ID} is 5.00 m away (more than 4.99 m): navigate there first"
    # 0: no limit
    assert goal_problem(PAD_ID, PAD, (-90.0, 3.0, 1.5), max_pad_distance=0.0,
                        min_altitude=0.8) is None
    # a limit below a metre holds too
    assert goal_problem(PAD_ID, PAD, (4.4, 3.0, 1.5), max_pad_distance=0.5,
                        min_altitude=0.8) is not None


def test_a_vehicle_too_low_above_the_pad_is_told_to_take_off():
    lowest = 0.8 - TAKEOFF_MARGIN
    pad = (5.0, 3.0, 0.25)
    assert goal_problem(PAD_ID, pad, (5.0, 3.0, pad[2] + lowest), max_pad_distance=5.0,
                        min_altitude=0.8) is None
    problem = goal_problem(PAD_ID, pad, (5.0, 3.0, pad[2] + lowest - 0.01),
                           max_pad_distance=5.0, min_altitude=0.8)
    assert problem == "the vehicle is 0.59 m above the pad: take off first (at least 0.8 m)"


# -- which marker, how wide a search ------------------------------------------------------
def test_the_pads_marker_is_the_first_detection_with_its_id():
    a, b = Measurement((0.1, 0.0), 1.0), Measurement((0.2, 0.0), 1.0)
    assert pad_marker([(3, Measurement((9.0, 9.0), 1.0)), (PAD_ID, a), (PAD_ID, b)],
                      PAD_ID) is a
    assert pad_marker([(3, a), (12, b)], PAD_ID) is None
    assert pad_marker([], PAD_ID) is None


def test_the_detections_after_the_pads_are_not_read():
    read: list[int] = []

    def detections():
        for marker_id in (3, PAD_ID, 9):
            read.append(marker_id)
            yield marker_id, Measurement((0.0, 0.0), 1.0)

    assert pad_marker(detections(), PAD_ID) is not None
    assert read == [3, PAD_ID]


def test_search_rings_cover_the_radius():
    assert search_rings(1.6, 0.8) == 2  # exactly two spacings
    assert search_rings(1.61, 0.8) == 3
    assert search_rings(0.1, 0.8) == 1  # at least one ring


def _search_moves(world: _World, policy: PrecisionLandPolicy, count: int) -> list[Move]:
    world.visible = False
    moves: list[Move] = []
    while len(moves) < count:
        command = world.frame(policy, S // 4)
        if isinstance(command, Move):
            moves.append(command)
            world.fly(policy, command)
    return moves


def test_a_goal_search_radius_sizes_the_search_spiral():
    world = _World((4.0, 3.0, 1.5))
    policy = _policy(world, search_radius=2.0, search_spacing=0.8, search_timeout_s=600.0)
    assert policy.params.search_rings == 3
    points = 1 + 8 * 3
    moves = _search_moves(world, policy, points + 1)
    reach = max(max(abs(m.position[0] - PAD[0]), abs(m.position[1] - PAD[1])) for m in moves)
    assert reach == pytest.approx(3 * 0.8)
    assert moves[points].position == pytest.approx(moves[0].position)  # round again


def test_a_small_search_radius_searches_one_ring():
    world = _World((4.0, 3.0, 1.5))
    policy = _policy(world, search_radius=0.5, search_rings=3, search_spacing=0.8,
                     search_timeout_s=600.0)
    assert policy.params.search_rings == 1
    moves = _search_moves(world, policy, 10)
    assert moves[9].position == pytest.approx(moves[0].position)  # 1 + 8 points, round again


def test_without_a_search_radius_the_configured_rings_are_searched():
    world = _World((4.0, 3.0, 1.5))
    policy = PrecisionLandPolicy(LandingParams(search_rings=0), LandingStrategy.CAPTURE,
                                 PAD_ID, PAD, world.pose(), world.now_ns)
    assert policy.params.search_rings == 0
    moves = _search_moves(world, policy, 3)  # no ring: the pad's position, again and again
    assert all(m.position == pytest.approx((PAD[0], PAD[1], P.search_altitude))
               for m in moves)


# -- a landing, tick by tick ---------------------------------------------------------------
def test_it_starts_at_the_vehicles_height_and_holds_its_heading():
    world = _World((4.6, 3.2, 1.7), yaw=1.2)
    policy = _policy(world)
    assert policy.reference_altitude == pytest.approx(1.7)
    assert policy.phase is Phase.SEARCH
    assert math.isnan(policy.lateral_error)
    move = _until_command(world, policy)
    assert isinstance(move, Move)
    assert move.yaw == 1.2
    assert move.position == pytest.approx((PAD[0], PAD[1], 1.7))
    assert policy.phase is Phase.ALIGN
    assert policy.lateral_error == pytest.approx(math.hypot(0.4, 0.2), abs=0.011)


def test_while_a_move_is_flown_it_waits_then_measures_again():
    world = _World((4.6, 3.0, 1.5))
    policy = _policy(world)
    move = _until_command(world, policy)
    assert isinstance(move, Move) and policy.moving
    for _ in range(5):  # the move is still flown: only the filter learns
        assert isinstance(world.frame(policy), Wait)
    world.fly(policy, move)
    assert not policy.moving
    assert isinstance(_until_command(world, policy), Move)


def test_aligned_it_steps_down_to_the_touchdown_then_lands():
    world = _World((4.6, 3.0, 1.5))
    policy = _policy(world)
    altitudes: list[float] = []
    for _ in range(10):
        command = _until_command(world, policy)
        if isinstance(command, Touchdown):
            break
        assert isinstance(command, Move)
        altitudes.append(command.position[2])
        world.fly(policy, command)
    else:
        raise AssertionError("no touchdown")
    # aligning at 1.5 m, then one descent_step per aligned frame down to min_altitude
    assert altitudes == pytest.approx([1.5, 1.2, 0.9])
    assert policy.phase is Phase.FINAL_LAND
    finish = policy.land_ended(True, "")
    assert finish == Finish(Outcome.SUCCEEDED, f"landed on pad {PAD_ID}") and finish.success


def test_a_failed_final_landing_is_a_flight_error():
    world = _World((5.0, 3.0, 1.5))
    policy = _policy(world)
    finish = policy.land_ended(False, "FCU refused NAV_LAND")
    assert finish == Finish(Outcome.FLIGHT_ERROR, "land failed: FCU refused NAV_LAND")
    assert not finish.success


def test_marker_lost_while_aligning_climbs_back_to_search_then_reacquires():
    world = _World((4.6, 3.0, 1.2))
    policy = _policy(world, retries=1, search_altitude=1.5)
    move = _until_command(world, policy)
    world.fly(policy, move)
    world.visible = False
    # not seen for less than lost_timeout_s: it waits where it is
    assert isinstance(world.frame(policy, int(P.lost_timeout_s * S) - FRAME_NS), Wait)
    assert policy.phase is Phase.ALIGN
    climb = world.frame(policy, 2 * FRAME_NS)
    assert isinstance(climb, Move)
    assert climb.position == pytest.approx((PAD[0], PAD[1], 1.5))  # the spiral's centre
    assert policy.phase is Phase.SEARCH
    assert math.isclose(policy.reference_altitude, 1.5)
    world.fly(policy, climb)
    world.visible = True
    world.position = (4.8, 3.1, 1.5)  # drifted a little while searching
    again = _until_command(world, policy)
    assert policy.phase is Phase.ALIGN
    assert isinstance(again, Move) and again.position == pytest.approx((PAD[0], PAD[1], 1.5))


def test_marker_lost_with_no_retry_left_ends_with_marker_lost():
    world = _World((4.6, 3.0, 1.2))
    policy = _policy(world, retries=0)
    world.fly(policy, _until_command(world, policy))
    world.visible = False
    finish = world.frame(policy, int(P.lost_timeout_s * S) + FRAME_NS)
    assert finish == Finish(Outcome.MARKER_LOST,
                            f"pad {PAD_ID}: marker lost during the descent: no marker for "
                            "2 s at 1.20 m above the pad")


def test_never_seen_ends_with_marker_not_found_after_the_search_timeout():
    world = _World((4.0, 3.0, 1.5), visible=False)
    policy = _policy(world, search_timeout_s=5.0)
    commands = [world.frame(policy, S // 2) for _ in range(10)]  # up to 5 s: searching
    assert not any(isinstance(c, Finish) for c in commands)
    finish = world.frame(policy, S // 2)
    assert isinstance(finish, Finish) and finish.outcome is Outcome.MARKER_NOT_FOUND
    assert finish.message.startswith(f"pad {PAD_ID}: marker not found: ")


def test_the_whole_landing_times_out_on_a_frame():
    world = _World((4.6, 3.0, 1.5))
    policy = _policy(world, timeout_s=10.0, search_timeout_s=100.0)
    finish = world.frame(policy, 10 * S + 1)
    assert finish == Finish(Outcome.TIMEOUT, f"pad {PAD_ID}: timeout: not landed after 10 s")


def test_no_frames_at_all_times_out_at_a_poll():
    world = _World((4.6, 3.0, 1.5), now_ns=3 * S)
    policy = _policy(world, timeout_s=10.0)
    assert policy.poll(13 * S, False) is None  # 10 s: not more
    assert policy.poll(13 * S + 1, True) is None  # frames waiting: they decide
    finish = policy.poll(13 * S + 1, False)
    assert finish == Finish(Outcome.TIMEOUT, f"pad {PAD_ID}: no marker frames for 10 s "
                                             "(is the scanner running?)")


def test_the_capture_pose_goes_with_a_seen_marker_only_with_the_capture_strategy():
    world = _World((4.6, 3.0, 1.5))
    seen = world.marker()
    capture = _policy(world)
    assert capture.needs_capture_pose(seen)
    assert not capture.needs_capture_pose(None)
    assert not _policy(world, LandingStrategy.SEED).needs_capture_pose(seen)


# -- how moves end, cancel -----------------------------------------------------------------
def _moving(world: _World) -> PrecisionLandPolicy:
    policy = _policy(world)
    assert isinstance(_until_command(world, policy), Move) and policy.moving
    return policy


def test_a_move_that_times_out_is_no_flight_error():
    world = _World((4.6, 3.0, 1.5))
    policy = _moving(world)
    ended = policy.reach_ended(False, True, "3.0 cm from the target")
    assert ended == Wait("correction move: 3.0 cm from the target")
    assert not policy.moving
    assert isinstance(_until_command(world, policy), Move)  # measures again from here


def test_a_move_that_fails_otherwise_is_a_flight_error():
    world = _World((4.6, 3.0, 1.5))
    policy = _moving(world)
    assert policy.reach_ended(False, False, "left offboard") == Finish(
        Outcome.FLIGHT_ERROR, "reach failed: left offboard")
    assert not policy.moving


def test_a_rejected_move_is_a_flight_error():
    world = _World((4.6, 3.0, 1.5))
    policy = _moving(world)
    assert policy.phase is Phase.ALIGN  # a correction move, not a search leg
    assert policy.reach_rejected("busy") == Finish(Outcome.FLIGHT_ERROR,
                                                   "reach rejected: busy")
    assert not policy.moving


def test_a_search_point_whose_reach_is_refused_is_skipped_and_the_search_goes_on():
    """Random arena 209, dark: a pad in a corner, a search point 0.4 m from the walls that
    the map had not shown; flight control refused its reach (outside its flyable volume)
    and the landing ended in a flight error. It is skipped like a blocked point now."""
    world = _World((4.0, 3.0, 1.5))
    policy = _policy(world, search_radius=2.0, search_spacing=0.8, search_timeout_s=600.0)
    _, second = _search_moves(world, policy, 2)
    refused = _until_command(world, policy)
    assert isinstance(refused, Move) and policy.phase is Phase.SEARCH
    why = "target (0.47, 0.4, 1.5) m is outside the flyable volume"
    assert policy.reach_rejected(why) == Wait(f"search point skipped: its reach was refused: "
                                              f"{why}")
    assert not policy.moving
    following = _until_command(world, policy)  # the next frame: the next point
    assert isinstance(following, Move)
    assert following.position != pytest.approx(refused.position)
    assert following.position != pytest.approx(second.position)


def test_cancel():
    finish = _policy(_World((4.6, 3.0, 1.5))).cancel()
    assert finish == Finish(Outcome.CANCELED, "canceled") and not finish.success


def test_a_move_ends_at_its_time_so_frames_exposed_during_it_are_not_fresh():
    """The camera publishes 50 ms after the exposure. The move ends; the frame read 30 ms
    later was exposed 20 ms before the end, so the decision waits for two frames exposed
    after it (min_fresh_frames 2)."""
    world = _World((4.6, 3.0, 1.5))
    policy = _policy(world)
    move = _until_command(world, policy)
    world.position = move.position
    end_ns = world.now_ns + S
    assert policy.reach_ended(True, False, "", end_ns) == Wait()
    latency_ns = 50_000_000

    def read(at_ns: int):
        return policy.frame(at_ns, world.marker(), world.pose(), world.position, 0.0,
                            at_ns - latency_ns)

    assert isinstance(read(end_ns + 30_000_000), Wait), "exposed during the move"
    assert isinstance(read(end_ns + 30_000_000 + FRAME_NS), Wait), "one fresh frame"
    assert isinstance(read(end_ns + 30_000_000 + 2 * FRAME_NS), Move), "two fresh frames"
