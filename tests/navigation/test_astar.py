"""A* (navigation/astar.py): optimal against networkx, typed errors, partial paths and the
line-of-sight shortcut."""

from __future__ import annotations

import math
import re

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navigation.astar import (
    CHUNK_EXPANSIONS,
    Heuristic,
    SearchResult,
    SearchStatus,
    Workspace,
    astar,
    path_length,
    plan,
    segment_free,
    shortcut,
    snap,
)
from navigation.errors import (
    GoalOccupied,
    NoPathFound,
    OutOfBounds,
    PlanningTimedOut,
    StartOccupied,
)
from navigation.voxel_graph import OFFSETS, GraphParams, VoxelGraph, build_graph

RES = 0.2


def params(**kw: object) -> GraphParams:
    base = dict(resolution=RES, occupied_threshold=0, corridor_threshold=1,
                footprint_radius=0.0, safety_margin=0.0, vertical_clearance=0.0)
    base.update(kw)
    return GraphParams(**base)  # type: ignore[arg-type]


def to_networkx(g: VoxelGraph) -> nx.Graph:
    G = nx.Graph()
    costs = g.step_costs
    for d, off in enumerate(OFFSETS):
        src = np.argwhere(g.edges[d])
        for a in src:
            G.add_edge(int(g.grid.flat(a[None])[0]), int(g.grid.flat((a + off)[None])[0]),
                       weight=float(costs[d]))
    return G


def random_graph(seed: int, n: int, density: float) -> VoxelGraph:
    rng = np.random.default_rng(seed)
    size = (n * RES, n * RES, 5 * RES)
    cubes = np.argwhere(rng.random((n, n, 5)) < density)
    pts = (cubes + 0.5) * RES
    pts = np.vstack([pts, [[size[0] - 0.1, size[1] - 0.1, size[2] - 0.1]]])  # never empty
    return build_graph(pts, (0, 0, 0), size, params())


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(5, 14), density=st.floats(0.0, 0.45))
def test_astar_cost_equals_networkx_and_every_step_is_an_edge(seed: int, n: int,
                                                               density: float) -> None:
    g = random_graph(seed, n, density)
    free = np.flatnonzero(g.free)
    if len(free) < 2:
        return
    rng = np.random.default_rng(seed + 1)
    s, t = (int(v) for v in rng.choice(free, 2, replace=False))
    G = to_networkx(g)
    result = astar(g, s, t)
    shared = Workspace(g.grid.size)
    for heuristic in (Heuristic.OCTILE, Heuristic.EUCLIDEAN):  # reused arrays, same answer
        again = astar(g, s, t, heuristic=heuristic, workspace=shared)
        assert again.cost == pytest.approx(result.cost, abs=1e-9) or (
            math.isinf(again.cost) and math.isinf(result.cost))
    try:
        want = nx.astar_path_length(G, s, t, weight="weight")
    except (nx.NetworkXNoPath, nx.NodeNotFound):
        assert result.status is SearchStatus.EXHAUSTED
        assert len(result.cells) == 0 and math.isinf(result.cost)
        # every cube joined to the start is closed once before giving up
        assert result.expansions == (len(nx.node_connected_component(G, s)) if s in G else 1)
        return
    assert result.status is SearchStatus.FOUND
    assert result.cost == pytest.approx(want, abs=1e-9)
    assert result.cells[0] == s and result.cells[-1] == t
    for a, b in zip(result.cells[:-1], result.cells[1:], strict=True):
        assert G.has_edge(int(a), int(b)), f"step {a} -> {b} is not an edge"
    steps = sum(G[int(a)][int(b)]["weight"] for a, b in zip(result.cells[:-1], result.cells[1:],
                                                               strict=True))
    assert steps == pytest.approx(result.cost, abs=1e-9)


def wall_graph(**kw: object) -> VoxelGraph:
    """A 6 x 4 x 2 m field with a wall at x = 3 from y = 0 to 3 m (a gap at the north)."""
    pts = np.array([(3.05, y, z) for y in np.arange(0.05, 3.0, 0.1)
                    for z in np.arange(0.05, 2.0, 0.1)])
    return build_graph(pts, (0, 0, 0), (6, 4, 2), params(**kw))


def test_plan_goes_around_the_wall_and_the_shortcut_keeps_it_collision_free() -> None:
    g = wall_graph(footprint_radius=0.3)
    p = plan(g, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0))
    assert p.points[0].tolist() == [1.0, 1.0, 1.0] and p.points[-1].tolist() == [5.0, 1.0, 1.0]
    assert max(p.points[:, 1]) > 3.0  # around the wall's end, not through it
    assert p.length <= p.graph_cost + 1e-9  # shortcut never longer
    assert len(p.points) < 10
    for a, b in zip(p.points[:-1], p.points[1:], strict=True):
        assert segment_free(g, a, b)
        for t in np.linspace(0, 1, 200):  # every sampled point is in a free cube
            cell = g.grid.cell_of(a + t * (b - a))[0]
            assert g.free[tuple(cell)]


def test_shortcut_keeps_a_waypoint_whose_skip_would_cross_the_wall() -> None:
    g = wall_graph()
    zigzag = np.array([[1.0, 1.0, 1.0], [3.0, 3.6, 1.0], [5.0, 1.0, 1.0]])
    assert not segment_free(g, zigzag[0], zigzag[2])
    assert len(shortcut(g, zigzag)) == 3
    straight = np.array([[1.0, 3.6, 1.0], [2.0, 3.6, 1.0], [5.0, 3.6, 1.0]])
    assert shortcut(g, straight).tolist() == [straight[0].tolist(), straight[2].tolist()]


def test_start_and_goal_checks_are_typed() -> None:
    g = wall_graph(footprint_radius=0.3)
    with pytest.raises(StartOccupied):
        plan(g, (3.05, 1.0, 1.0), (5.0, 1.0, 1.0))
    with pytest.raises(GoalOccupied):
        plan(g, (1.0, 1.0, 1.0), (3.2, 1.0, 1.0))
    with pytest.raises(OutOfBounds, match="outside the field"):
        plan(g, (1.0, 1.0, 1.0), (7.0, 1.0, 1.0))
    # a start too close to the wall snaps to the nearest free cube within the radius
    snapped = plan(g, (2.75, 1.0, 1.0), (1.0, 1.0, 1.0), snap_radius=0.5)
    assert snapped.points[0][0] < 2.75


def ring_graph() -> VoxelGraph:
    """A 6 x 6 x 2 m field with a closed square wall from 2 to 4 m."""
    ring = np.array([(x, y, z) for x in np.arange(2.05, 4.0, 0.1) for y in (2.05, 3.95)
                     for z in np.arange(0.05, 2.0, 0.1)]
                    + [(x, y, z) for x in (2.05, 3.95) for y in np.arange(2.05, 4.0, 0.1)
                       for z in np.arange(0.05, 2.0, 0.1)])
    return build_graph(ring, (0, 0, 0), (6, 6, 2), params())


def test_no_path_when_the_goal_is_walled_off() -> None:
    g = ring_graph()
    with pytest.raises(NoPathFound, match="not connected"):
        plan(g, (1.0, 1.0, 1.0), (3.0, 3.0, 1.0))


def test_the_expansion_limit_gives_a_partial_path_toward_the_goal_when_asked() -> None:
    g = wall_graph()
    start, goal = np.array([1.0, 1.0, 1.0]), np.array([5.0, 1.0, 1.0])
    with pytest.raises(PlanningTimedOut) as info:
        plan(g, start, goal, max_expansions=50, partial=True)
    partial = info.value.partial
    assert partial is not None and np.allclose(partial[0], g.grid.center(g.grid.cell_of(start)))
    assert np.linalg.norm(partial[-1] - goal) < np.linalg.norm(start - goal)
    with pytest.raises(PlanningTimedOut) as info:
        plan(g, start, goal, max_expansions=50)
    assert info.value.partial is None
    full = plan(g, start, goal, time_limit_s=30.0)
    assert path_length(full.points) == pytest.approx(full.length)


# -- the search's contract: reuse, limits, heuristics, bad input ---------------------------
def open_field(x: float, y: float, z: float, res: float = RES) -> VoxelGraph:
    """A field with no obstacle (the cloud's only point is in a boundary cube)."""
    return build_graph(np.array([[x - 0.01, y - 0.01, z - 0.01]]), (0, 0, 0), (x, y, z),
                       params(resolution=res))


def same_result(a: SearchResult, b: SearchResult) -> bool:
    return (np.array_equal(a.cells, b.cells) and a.expansions == b.expansions
            and a.status is b.status and (a.cost == b.cost or math.isinf(a.cost + b.cost)))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), density=st.floats(0.0, 0.4))
def test_a_workspace_reused_over_any_sequence_of_searches_answers_as_a_fresh_one(
        seed: int, density: float) -> None:
    g = random_graph(seed, 8, density)
    free = np.flatnonzero(g.free)
    if len(free) < 2:
        return
    rng = np.random.default_rng(seed)
    shared = Workspace(g.grid.size)
    for _ in range(6):  # found, exhausted and stopped searches leave the workspace behind
        s, t = (int(v) for v in rng.choice(free, 2))
        limit = None if rng.random() < 0.5 else int(rng.integers(0, 40))
        heuristic = Heuristic(int(rng.integers(0, 2)))
        fresh = astar(g, s, t, max_expansions=limit, heuristic=heuristic)
        reused = astar(g, s, t, max_expansions=limit, heuristic=heuristic, workspace=shared)
        assert same_result(fresh, reused)


def test_the_expansion_limit_stops_at_that_count_on_the_optimal_path_to_a_closed_cube() -> None:
    g = wall_graph()
    G = to_networkx(g)
    s, t = (snap(g, p, 0.0) for p in ((1.0, 1.0, 1.0), (5.0, 1.0, 1.0)))
    assert s is not None and t is not None
    full = astar(g, s, t)
    for limit in (0, 1, 7, 60, full.expansions - 1):
        part = astar(g, s, t, max_expansions=limit)
        assert part.status is SearchStatus.LIMIT and part.expansions == limit
        assert part.cells[0] == s
        end = int(part.cells[-1])
        want = 0.0 if end == s else nx.shortest_path_length(G, s, end, weight="weight")
        assert part.cost == pytest.approx(want, abs=1e-9)  # closed cubes have optimal costs
    assert astar(g, s, t, max_expansions=0).cells.tolist() == [s]
    assert astar(g, s, t, max_expansions=full.expansions).status is SearchStatus.FOUND


def boxed_goal_query() -> tuple[VoxelGraph, np.ndarray, np.ndarray]:
    """A 10 x 10 x 3.2 m field, open but for a closed column of walls from 4 to 6 m (floor
    to ceiling): from (1, 1, 1.5) the goal (5, 5, 1.5) is free but out of reach, and the
    search closes the ~30 k cubes outside, more than CHUNK_EXPANSIONS, before saying so."""
    side = np.arange(4.05, 6.0, 0.1)
    walls = np.array([(x, y, z) for z in np.arange(0.05, 3.2, 0.1) for a in side
                      for x, y in ((a, 4.05), (a, 5.95), (4.05, a), (5.95, a))])
    g = build_graph(walls, (0, 0, 0), (10.0, 10.0, 3.2), params())
    return g, np.array([1.0, 1.0, 1.5]), np.array([5.0, 5.0, 1.5])


def test_a_time_limit_looks_at_the_clock_between_chunks_and_resumes_exactly() -> None:
    g, start, goal = boxed_goal_query()
    s, t = snap(g, start, 0.0), snap(g, goal, 0.0)
    assert s is not None and t is not None
    ws = Workspace(g.grid.size)
    whole = astar(g, s, t, workspace=ws)
    assert whole.status is SearchStatus.EXHAUSTED
    assert whole.expansions > CHUNK_EXPANSIONS + 5000
    # a generous limit: the chunks add up to the same search
    assert same_result(astar(g, s, t, time_limit_s=600.0, workspace=ws), whole)
    # no time left: one chunk, then the clock says stop
    now = astar(g, s, t, time_limit_s=0.0, workspace=ws)
    assert now.status is SearchStatus.LIMIT and now.expansions == CHUNK_EXPANSIONS
    # both limits: the expansion limit is met exactly across chunks, same partial path
    limit = CHUNK_EXPANSIONS + 1000
    both = astar(g, s, t, time_limit_s=600.0, max_expansions=limit, workspace=ws)
    assert same_result(both, astar(g, s, t, max_expansions=limit, workspace=ws))
    assert both.expansions == limit
    # through plan: stopped by the clock, not told there is no path
    with pytest.raises(PlanningTimedOut, match=f"after {CHUNK_EXPANSIONS} expansions"):
        plan(g, start, goal, time_limit_s=0.0)
    with pytest.raises(NoPathFound, match=f"{whole.expansions} cubes searched"):
        plan(g, start, goal, time_limit_s=600.0)


def test_octile_is_the_tighter_heuristic_fewer_cubes_for_the_same_cost() -> None:
    g = open_field(6.0, 6.0, 1.2)
    s, t = (snap(g, p, 0.0) for p in ((0.3, 0.3, 0.5), (5.7, 4.3, 0.7)))
    assert s is not None and t is not None
    euclid = astar(g, s, t)
    octile = astar(g, s, t, heuristic=Heuristic.OCTILE)
    assert octile.cost == pytest.approx(euclid.cost, abs=1e-9)
    assert octile.expansions < euclid.expansions / 2
    for kind, result in ((Heuristic.OCTILE, octile), (Heuristic.EUCLIDEAN, euclid)):
        assert same_result(astar(g, s, t, heuristic=kind, time_limit_s=600.0), result)
    planned = plan(g, (0.3, 0.3, 0.5), (5.7, 4.3, 0.7), heuristic=Heuristic.OCTILE)
    assert planned.expansions == octile.expansions


def test_workspace_and_cube_checks() -> None:
    g = wall_graph()
    n = g.grid.size
    t = snap(g, (5.0, 1.0, 1.0), 0.0)
    assert t is not None
    with pytest.raises(ValueError, match=f"workspace for {n + 1} cubes, graph has {n}"):
        astar(g, t, t, workspace=Workspace(n + 1))
    with pytest.raises(ValueError, match="workspace for"):
        plan(g, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0), workspace=Workspace(n - 1))
    for s, goal in ((-1, t), (n, t), (t, -1), (t, n)):
        with pytest.raises(IndexError, match=rf"start {s} and goal {goal} must be cubes of "
                                             rf"the grid \(0 \.\. {n - 1}\)"):
            astar(g, s, goal)
    # cube 0 and the last are boundary cubes: valid indices, never free
    assert astar(g, 0, t).status is SearchStatus.EXHAUSTED
    assert astar(g, t, n - 1).status is SearchStatus.EXHAUSTED
    assert astar(g, t, 0).expansions > 1
    ws = Workspace(n)  # cube indices in int32: half the memory the search walks through
    assert {a.dtype for a in (ws.parent, ws.pos, ws.hn, ws.touched)} == {np.dtype(np.int32)}
    assert (ws.parent == -1).all() and (ws.pos == -1).all() and np.isinf(ws.g).all()


def test_error_messages_say_which_point_is_wrong_to_the_millimetre() -> None:
    g = wall_graph(footprint_radius=0.3)
    with pytest.raises(StartOccupied, match=re.escape(
            "start [3.05, 1.0, 1.0] m is in or too close to an obstacle (no free cube there)")):
        plan(g, (3.05049, 1.00001, 1.0), (5.0, 1.0, 1.0))
    with pytest.raises(GoalOccupied, match=re.escape(
            "goal [3.2, 1.0, 1.0] m is in or too close to an obstacle (no free cube there)")):
        plan(g, (1.0, 1.0, 1.0), (3.20049, 1.0, 1.0))
    with pytest.raises(OutOfBounds, match=re.escape("[7.123, 1.0, 1.0] m is outside the field")):
        plan(g, (1.0, 1.0, 1.0), (7.12349, 1.0, 1.0))
    with pytest.raises(StartOccupied, match=re.escape("start [3.0, 1.0, 1.0] m")):
        plan(g, (3, 1, 1), (5, 1, 1))  # integers are metres too
    with pytest.raises(ValueError):  # a point has three coordinates
        plan(g, (1.0, 1.0), (5.0, 1.0, 1.0))
    ring = ring_graph()
    with pytest.raises(NoPathFound, match=re.escape(
            "no path from [1.0, 1.001, 1.0] to [3.0, 3.0, 1.0] m: the goal is not connected "
            "to the start (")):
        plan(ring, (1.0, 1.00123, 1.0), (3.0, 3.0, 1.0))
    with pytest.raises(PlanningTimedOut, match="search stopped after 5 expansions without "
                                               "reaching the goal"):
        plan(g, (1.0, 1.0, 1.0), (5.0, 1.0, 1.0), max_expansions=5)


# -- snapping, waypoints, helpers ------------------------------------------------------------
def nearest_free(g: VoxelGraph, point: np.ndarray, radius: float) -> int | None:
    """Brute force: the free cube whose centre is nearest, first in index order."""
    cubes = np.flatnonzero(g.free)
    d = np.linalg.norm(g.grid.center(g.grid.unflat(cubes)) - point, axis=1)
    i = int(np.argmin(d))
    return int(cubes[i]) if d[i] <= radius else None


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), density=st.floats(0.2, 0.9),
       radius=st.floats(0.0, 0.9), u=st.tuples(*[st.floats(0.0, 0.999)] * 3))
def test_snap_is_the_cube_holding_the_point_or_the_nearest_free_centre_within_the_radius(
        seed: int, density: float, radius: float, u: tuple[float, float, float]) -> None:
    g = random_graph(seed, 9, density)
    if not g.free.any():
        return
    point = np.asarray(u) * np.asarray(g.grid.shape) * RES
    cell = g.grid.cell_of(point)[0]
    got = snap(g, point, radius)
    if g.free[tuple(cell)]:
        assert got == int(g.grid.flat(cell[None])[0])
    else:
        assert got == nearest_free(g, point, radius)


def test_snap_takes_a_centre_exactly_at_the_radius() -> None:
    g = open_field(2.0, 2.0, 2.0, res=0.25)  # binary fractions: exact distances
    wall = g.grid.center(np.array([[0, 3, 3]]))[0]  # a boundary cube, never free
    inside = g.grid.center(np.array([[1, 3, 3]]))[0]
    assert snap(g, wall, 0.25) == int(g.grid.flat(np.array([[1, 3, 3]]))[0])
    assert snap(g, wall, 0.2499) is None
    assert snap(g, wall, 0.0) is None
    assert snap(g, inside, 0.0) == int(g.grid.flat(np.array([[1, 3, 3]]))[0])
    high = g.grid.center(np.array([[6, 7, 6]]))[0]  # the free cube is on the high side
    assert snap(g, high, 0.25) == int(g.grid.flat(np.array([[6, 6, 6]]))[0])


def test_waypoints_end_at_the_points_when_inside_their_cubes_else_at_the_snapped_centres(
        ) -> None:
    g = wall_graph(footprint_radius=0.3)
    s, t = (1.01, 1.02, 1.03), (4.98, 1.01, 0.97)
    raw = plan(g, s, t, use_shortcut=False)
    assert raw.points[0].tolist() == list(s) and raw.points[-1].tolist() == list(t)
    cells = g.grid.cell_of(raw.points[1:-1])
    assert np.all(np.abs(np.diff(cells, axis=0)).max(axis=1) == 1)  # one cube per step
    near_s, near_t = (2.75, 1.0, 1.0), (3.35, 1.0, 1.0)  # too close to the wall
    snapped = plan(g, near_s, near_t, snap_radius=0.5, use_shortcut=False)
    s_cube, t_cube = snap(g, near_s, 0.5), snap(g, near_t, 0.5)
    assert s_cube is not None and t_cube is not None
    assert snapped.points[0].tolist() == g.grid.center(g.grid.unflat(s_cube))[0].tolist()
    assert snapped.points[-1].tolist() == g.grid.center(g.grid.unflat(t_cube))[0].tolist()
    assert snapped.expansions == astar(g, s_cube, t_cube).expansions
    assert snapped.graph_cost == pytest.approx(astar(g, s_cube, t_cube).cost)


def test_a_partial_path_is_shortened_only_when_asked() -> None:
    g = wall_graph()
    start, goal = (1.0, 1.0, 1.0), (5.0, 1.0, 1.0)
    with pytest.raises(PlanningTimedOut) as raw:
        plan(g, start, goal, max_expansions=200, partial=True, use_shortcut=False)
    with pytest.raises(PlanningTimedOut) as short:
        plan(g, start, goal, max_expansions=200, partial=True)
    cells = astar(g, snap(g, start, 0.0) or 0, snap(g, goal, 0.0) or 0, max_expansions=200).cells
    assert raw.value.partial is not None and short.value.partial is not None
    assert raw.value.partial.tolist() == g.grid.center(g.grid.unflat(cells)).tolist()
    assert len(short.value.partial) < len(raw.value.partial)
    assert short.value.partial[[0, -1]].tolist() == raw.value.partial[[0, -1]].tolist()


def test_path_length_sums_the_segments() -> None:
    assert path_length([[0, 0, 0], [3, 4, 0], [3, 4, 12]]) == 17.0
    assert path_length([[1, 2, 3]]) == 0.0
    assert path_length(np.empty((0, 3))) == 0.0


def test_shortcut_returns_float_waypoints_for_any_count() -> None:
    g = wall_graph()
    assert shortcut(g, np.empty((0, 3))).shape == (0, 3)
    one = shortcut(g, [[1, 1, 1]])
    assert one.dtype == np.float64 and one.tolist() == [[1.0, 1.0, 1.0]]
    two = np.array([[1.0, 1.0, 1.0], [5.0, 3.6, 1.0]])
    assert shortcut(g, two).tolist() == two.tolist()
    assert not segment_free(g, (1.0, 1.0, 1.0), (7.0, 1.0, 1.0))  # leaves the field
    assert segment_free(g, (1, 3, 1), (5, 3.6, 1))
    assert segment_free(g, [[1.0, 3.0, 1.0]], [[5.0], [3.6], [1.0]])  # any shape of 3 values
    with pytest.raises(ValueError):
        segment_free(g, (1.0, 3.0, 1.0, 2.0), (5.0, 3.6, 1.0))
