"""navigation/search_legs.py and the pad search it shapes (precision_land_policy.py): each
search leg judged on the path finder's answer. First the verdicts alone, then the policy
walked tick by tick over a real voxel graph and A* (the path finder's own functions and
parameters, its error table and the node's reading of it), with boxes in the search area:
no flown leg comes within the navigator's clearance of a map point, a point in a box's
clearance is skipped, a leg across a box is flown round, and with nothing mapped near the
pad the spiral is the one it always was."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_control.policy import Finish
from navigation.astar import plan
from navigation.errors import PlanningError
from navigation.params import PathFinderParams
from navigation.path_finder_node import RESULT_OF
from navigation.precision_land_node import SEARCH_POINT_BLOCKED
from navigation.precision_land_policy import (
    CheckLeg,
    Move,
    PlanAnswer,
    PrecisionLandPolicy,
)
from navigation.precision_landing import LandingParams, LandingStrategy, Pose, search_pattern
from navigation.search_legs import Leg, LegKind, judge_leg
from navigation.voxel_graph import VoxelGraph, build_graph
from runtime.parameters import load_parameters

FINDER = load_parameters(PathFinderParams, "path_finder")  # the configured path finder
GRAPH = FINDER.graph()  # clearance 0: the navigator's (footprint + margin)
N, M = GRAPH.inflation_cubes
HORIZONTAL = N * GRAPH.resolution  # m, what a free cube keeps from every map point, x and y
VERTICAL = M * GRAPH.resolution  # m, ... or above and below
#: the line check samples every res / 8: a point between two samples is res / 16 from one
SAMPLING = GRAPH.resolution / 16.0 + 1e-9
FIELD_MIN, FIELD_MAX = (0.0, 0.0, 0.0), (8.0, 8.0, 3.0)
PAD = (4.0, 4.0, 0.0)
WIDE = 2.0  # m, the mission's wide search radius (config/mission.yaml): 3 rings of 0.8 m
S = 1_000_000_000


# -- the verdicts ----------------------------------------------------------------------------
A, B = (0.0, 0.0, 1.5), (1.0, 0.0, 1.5)


def test_a_straight_path_is_a_clear_leg_to_the_point():
    assert judge_leg(A, B, PlanAnswer.PATH, np.array([A, B]), max_detour=2.0) == \
        Leg(LegKind.CLEAR, B)


def test_a_point_the_planner_snapped_or_refused_is_skipped():
    snapped = np.array([A, (0.9, 0.0, 1.5)])
    assert judge_leg(A, B, PlanAnswer.PATH, snapped, max_detour=2.0).kind is LegKind.SKIP
    assert judge_leg(A, B, PlanAnswer.BLOCKED, max_detour=2.0).kind is LegKind.SKIP


def test_without_an_answer_from_the_map_the_leg_is_flown_as_it_was():
    assert judge_leg(A, B, PlanAnswer.UNKNOWN, max_detour=2.0) == \
        Leg(LegKind.UNCHECKED, B, "the map says nothing of this leg")


def test_a_way_round_is_flown_to_its_first_waypoint_within_the_detour():
    round_ = np.array([A, (0.5, 0.5, 1.5), B])  # 1.414 m against 1 m
    leg = judge_leg(A, B, PlanAnswer.PATH, round_, max_detour=0.5)
    assert leg.kind is LegKind.VIA and leg.target == (0.5, 0.5, 1.5)
    assert judge_leg(A, B, PlanAnswer.PATH, round_, max_detour=0.4).kind is LegKind.SKIP


def test_a_start_snapped_out_of_a_clearance_is_left_first():
    # the planner's path begins at the free cube beside the vehicle: that hop is flown first
    path = np.array([(0.1, 0.1, 1.5), B])
    leg = judge_leg(A, B, PlanAnswer.PATH, path, max_detour=2.0)
    assert leg.kind is LegKind.VIA and leg.target == (0.1, 0.1, 1.5)


# -- the search over a real graph --------------------------------------------------------------
def box_points(center: tuple[float, float], size: tuple[float, float, float]) -> np.ndarray:
    """A box standing on the floor as the mapping node holds it: its faces and top as
    points 0.1 m apart (the map's voxels)."""
    (cx, cy), (sx, sy, h) = center, size
    xs = np.arange(cx - sx / 2, cx + sx / 2 + 1e-9, 0.1)
    ys = np.arange(cy - sy / 2, cy + sy / 2 + 1e-9, 0.1)
    zs = np.arange(0.05, h + 1e-9, 0.1)
    grid = np.array(np.meshgrid(xs, ys, zs, indexing="ij")).reshape(3, -1).T
    on_face = (np.isclose(grid[:, 0], xs[0]) | np.isclose(grid[:, 0], xs[-1])
                | np.isclose(grid[:, 1], ys[0]) | np.isclose(grid[:, 1], ys[-1])
                | np.isclose(grid[:, 2], zs[-1]))
    return grid[on_face]


def graph_of(points: np.ndarray) -> VoxelGraph:
    far = np.array([[0.5, 7.5, 0.05]])  # the path finder needs a cloud: a point in a corner
    return build_graph(np.vstack([points, far]), FIELD_MIN, FIELD_MAX, GRAPH)


def planner(graph: VoxelGraph):
    """The path finder node's answer on ``graph`` as the precision-land node reads it."""

    def answer(check: CheckLeg) -> tuple[PlanAnswer, np.ndarray | None]:
        try:
            planned = plan(graph, check.start, check.goal, snap_radius=FINDER.snap_radius)
        except PlanningError as exc:
            code = RESULT_OF[type(exc)]
            return (PlanAnswer.BLOCKED if code in SEARCH_POINT_BLOCKED
                    else PlanAnswer.UNKNOWN), None
        return PlanAnswer.PATH, planned.points

    return answer


def no_map(check: CheckLeg) -> tuple[PlanAnswer, np.ndarray | None]:
    return PlanAnswer.UNKNOWN, None


def fly_search(answer, start: tuple[float, float, float], moves: int,
               ) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[Move]]:
    """The wide search with the marker never in view, each move flown exactly: the flown
    segments and the moves, up to ``moves`` of them (or 400 frames)."""
    policy = PrecisionLandPolicy(LandingParams(search_timeout_s=1e4, timeout_s=1e4),
                                 LandingStrategy.CAPTURE, 7, PAD, Pose(start, 0.0), 0,
                                 search_radius=WIDE)
    here, now = start, 0
    segments: list[tuple[np.ndarray, np.ndarray]] = []
    flown: list[Move] = []
    for _ in range(400):
        now += S // 4
        command = policy.frame(now, None, Pose(here, 0.0), here, 0.0)
        while isinstance(command, CheckLeg):
            assert command.start == here  # checked from where the vehicle is
            command = policy.leg_planned(command, *answer(command), now)
        assert not isinstance(command, Finish), command
        if isinstance(command, Move):
            segments.append((np.array(here), np.array(command.position)))
            flown.append(command)
            here = command.position
            policy.reach_ended(True, False, "", now)
            if len(flown) >= moves:
                break
    return segments, flown


def intrudes(a: np.ndarray, b: np.ndarray, points: np.ndarray, horizontal: float,
             vertical: float) -> np.ndarray:
    """Which ``points`` come inside the box of half-sizes (``horizontal``, ``horizontal``,
    ``vertical``) [m] around some point of the segment a-b (exact: per axis the interval
    of the segment's parameter inside, intersected)."""
    half = np.array([horizontal, horizontal, vertical])
    d = b - a
    lo, hi = np.zeros(len(points)), np.ones(len(points))
    for i in range(3):
        if abs(d[i]) < 1e-12:
            inside = np.abs(a[i] - points[:, i]) < half[i]
            hi = np.where(inside, hi, -1.0)
            continue
        t0 = (points[:, i] - half[i] - a[i]) / d[i]
        t1 = (points[:, i] + half[i] - a[i]) / d[i]
        lo, hi = np.maximum(lo, np.minimum(t0, t1)), np.minimum(hi, np.maximum(t0, t1))
    return lo < hi


def test_the_clearance_check_finds_a_point_beside_a_segment():
    a, b = np.array([0.0, 0.0, 1.5]), np.array([2.0, 0.0, 1.5])
    pts = np.array([[1.0, 0.39, 1.5], [1.0, 0.41, 1.5], [1.0, 0.0, 1.75], [2.39, 0.0, 1.5]])
    assert intrudes(a, b, pts, 0.4, 0.2).tolist() == [True, False, False, True]


def test_with_nothing_mapped_near_the_pad_the_spiral_is_the_one_flown_without_a_map():
    far = box_points((7.4, 7.4), (0.3, 0.3, 2.5))  # a pillar 0.85 m outside the search
    start = (4.3, 4.0, 1.2)
    _, plain = fly_search(no_map, start, 30)
    _, mapped = fly_search(planner(graph_of(far)), start, 30)
    assert mapped == plain
    spiral = search_pattern(PAD[:2], 0.8, 3)
    assert [m.position[:2] for m in plain[:25]] == [tuple(p) for p in spiral]


def test_a_search_point_inside_a_boxs_clearance_is_skipped():
    box = box_points((5.6, 4.0), (0.4, 0.4, 1.5))  # on ring 2's first point (5.6, 4.0)
    _, flown = fly_search(planner(graph_of(box)), (4.3, 4.0, 1.2), 40)
    targets = [m.position[:2] for m in flown]
    assert (5.6, 4.0) not in [(round(x, 6), round(y, 6)) for x, y in targets]
    assert len(targets) == 40  # the search goes on round the rest of the spiral


def test_a_leg_across_a_box_is_flown_round_and_its_point_still_reached():
    # a pole between ring 2's last point (5.6, 2.4) and ring 3's first (6.4, 4.0), 0.8 m
    # from both: the straight leg from one to the other passes through it
    pole = box_points((6.0, 3.2), (0.2, 0.2, 2.5))
    segments, flown = fly_search(planner(graph_of(pole)), (4.3, 4.0, 1.2), 40)
    targets = [(round(m.position[0], 6), round(m.position[1], 6)) for m in flown]
    i = targets.index((5.6, 2.4))
    assert targets[i + 1] != (6.4, 4.0), "the straight leg through the pole was flown"
    assert (6.4, 4.0) in targets[i + 2:i + 6], "the point behind the pole was not reached"
    for a, b in segments:
        assert not intrudes(a, b, pole, HORIZONTAL - SAMPLING, VERTICAL - SAMPLING).any()


def test_every_search_leg_is_checked_from_where_the_vehicle_is():
    checks: list[CheckLeg] = []

    def counting(check: CheckLeg) -> tuple[PlanAnswer, np.ndarray | None]:
        checks.append(check)
        return no_map(check)

    _, flown = fly_search(counting, (4.3, 4.0, 1.2), 10)
    assert len(checks) == len(flown) == 10
    assert [c.goal for c in checks] == [m.position for m in flown]


boxes = st.lists(st.tuples(st.floats(1.2, 6.8), st.floats(1.2, 6.8), st.floats(0.2, 1.2),
                           st.floats(0.2, 1.2), st.floats(0.3, 2.8)), min_size=1, max_size=3)


@settings(max_examples=40, deadline=None)
@given(boxes=boxes)
def test_no_flown_search_leg_comes_within_the_navigators_clearance_of_the_map(boxes):
    # the pad stands clear of obstacles (the arena's rule): boxes keep 0.9 m off its centre
    kept = [(x, y, sx, sy, h) for x, y, sx, sy, h in boxes
            if max(abs(x - PAD[0]) - sx / 2, abs(y - PAD[1]) - sy / 2) > 0.9]
    if not kept:
        return
    points = np.vstack([box_points((x, y), (sx, sy, h)) for x, y, sx, sy, h in kept])
    graph = graph_of(points)
    start = (PAD[0], PAD[1], 1.2)  # above the pad, where the landing started
    segments, flown = fly_search(planner(graph), start, 60)
    for a, b in segments:
        inside = intrudes(a, b, points, HORIZONTAL - SAMPLING, VERTICAL - SAMPLING)
        assert not inside.any(), (f"leg {a.round(3)} -> {b.round(3)} comes within "
                                  f"{HORIZONTAL} m (x, y) / {VERTICAL} m (z) of "
                                  f"{points[inside][0]}")
    spiral = {(round(p[0], 6), round(p[1], 6)) for p in search_pattern(PAD[:2], 0.8, 3)}
    for m in flown:  # every search point flown to is in a free cube
        if (round(m.position[0], 6), round(m.position[1], 6)) in spiral:
            cell = graph.grid.cell_of(np.array(m.position))[0]
            assert graph.free[tuple(cell)]


def test_the_detour_limit_is_a_parameter_with_a_range():
    with pytest.raises(ValueError, match="search_detour"):
        LandingParams(search_detour=-0.1)
    assert math.isfinite(LandingParams().search_detour)
