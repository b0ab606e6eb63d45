"""A* (navigation/astar.py): optimal against networkx, typed errors, partial paths and the
line-of-sight shortcut."""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navigation.astar import (
    Heuristic,
    SearchStatus,
    Workspace,
    astar,
    path_length,
    plan,
    segment_free,
    shortcut,
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
    assert np.isinf(shared.g).all() and (shared.pos == -1).all()  # reset after each search
    try:
        want = nx.astar_path_length(G, s, t, weight="weight")
    except (nx.NetworkXNoPath, nx.NodeNotFound):
        assert result.status is SearchStatus.EXHAUSTED
        assert len(result.cells) == 0
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


def test_no_path_when_the_goal_is_walled_off() -> None:
    ring = np.array([(x, y, z) for x in np.arange(2.05, 4.0, 0.1) for y in (2.05, 3.95)
                     for z in np.arange(0.05, 2.0, 0.1)]
                    + [(x, y, z) for x in (2.05, 3.95) for y in np.arange(2.05, 4.0, 0.1)
                       for z in np.arange(0.05, 2.0, 0.1)])
    g = build_graph(ring, (0, 0, 0), (6, 6, 2), params())
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
