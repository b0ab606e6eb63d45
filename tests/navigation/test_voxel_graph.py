"""The seed's graph rules (navigation/voxel_graph.py), one test per rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navigation.astar import plan
from navigation.errors import EmptyCloud, InvalidBounds, ResolutionTooSmall
from navigation.voxel_graph import (
    OFFSETS,
    OPPOSITE,
    GraphParams,
    Grid,
    build_graph,
    cache_key,
    cached_graph,
    count_points,
    update_graph,
)

FIELD_MIN = (0.0, 0.0, 0.0)
FIELD_MAX = (4.0, 4.0, 2.0)
RES = 0.2
# a single far point: the cloud is not empty, nothing near the middle of the field
FAR = np.array([[3.85, 3.85, 1.85]])


def params(**kw: object) -> GraphParams:
    base = dict(resolution=RES, occupied_threshold=2, corridor_threshold=1,
                footprint_radius=0.0, safety_margin=0.0, vertical_clearance=0.0)
    base.update(kw)
    return GraphParams(**base)  # type: ignore[arg-type]


def centre(i: int, j: int, k: int) -> np.ndarray:
    return (np.array([i, j, k]) + 0.5) * RES


def test_boundary_cubes_are_not_viable_and_inner_ones_are() -> None:
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params())
    nx, ny, nz = g.grid.shape
    assert (nx, ny, nz) == (20, 20, 10)
    for cell in [(0, 5, 5), (nx - 1, 5, 5), (5, 0, 5), (5, ny - 1, 5), (5, 5, 0), (5, 5, nz - 1)]:
        assert not g.viable[cell], f"boundary cube {cell} is viable"
        assert not g.edges[(slice(None), *cell)].any()
    assert g.viable[1, 1, 1] and g.viable[10, 10, 5]


def test_a_cube_with_more_points_than_the_threshold_is_not_viable() -> None:
    at = centre(10, 10, 5)
    three = np.vstack([FAR, np.repeat(at[None], 3, axis=0)])
    two = np.vstack([FAR, np.repeat(at[None], 2, axis=0)])
    p = params(occupied_threshold=2)
    assert not build_graph(three, FIELD_MIN, FIELD_MAX, p).viable[10, 10, 5]
    assert build_graph(two, FIELD_MIN, FIELD_MAX, p).viable[10, 10, 5]


def test_points_outside_the_field_are_dropped() -> None:
    outside = np.array([[-0.1, 2.0, 1.0], [2.0, 4.05, 1.0], [2.0, 2.0, 2.5]])
    g = build_graph(np.vstack([FAR, outside]), FIELD_MIN, FIELD_MAX, params())
    assert int(g.counts.sum()) == 1


def test_neighbours_are_eight_horizontal_plus_up_and_down() -> None:
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params())
    got = {tuple(int(v) for v in np.subtract(n, (10, 10, 5))) for n in g.neighbours((10, 10, 5))}
    want = {(dx, dy, 0) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)}
    assert got == want | {(0, 0, 1), (0, 0, -1)}
    assert (1, 1, 1) not in got and (1, 0, 1) not in got  # no slanted vertical edges


def test_up_and_down_edges_exist_and_are_symmetric() -> None:
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params())
    up, down = 8, 9
    assert tuple(OFFSETS[up]) == (0, 0, 1) and tuple(OFFSETS[down]) == (0, 0, -1)
    assert g.edges[up, 10, 10, 5] and g.edges[down, 10, 10, 6]
    for d in range(len(OFFSETS)):  # every edge has its reverse
        src = np.argwhere(g.edges[d])
        dst = src + OFFSETS[d]
        assert g.edges[OPPOSITE[d]][tuple(dst.T)].all()


def test_edge_cost_is_the_euclidean_distance_between_centres() -> None:
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params())
    for d, off in enumerate(OFFSETS):
        assert g.step_costs[d] == pytest.approx(np.linalg.norm(centre(*(np.array([5, 5, 5]) + off))
                                                               - centre(5, 5, 5)))


def test_a_corridor_too_narrow_for_the_footprint_has_no_edge() -> None:
    # two walls of points along y at x = 1.0 and x = 2.0: a 1 m slot (5 cubes wide)
    ys = np.arange(0.05, 4.0, 0.1)
    zs = np.arange(0.05, 2.0, 0.1)
    wall = np.array([(x, y, z) for x in (0.9, 2.1) for y in ys for z in zs])
    mid = (7, 10, 5)  # x 1.4-1.6: the slot's centre cubes are 7 (x 1.4..1.6)
    narrow = build_graph(wall, FIELD_MIN, FIELD_MAX, params(footprint_radius=0.35,
                                                            safety_margin=0.05))
    # inflation 0.2 * ceil(0.4 / 0.2) = 0.4 m: cube 7's box spans cubes 5..9 = x 1.0..2.0
    assert narrow.params.inflation_cubes == (2, 0)
    assert narrow.free[mid] and narrow.edges[2][mid]  # along the slot (+y): free
    wide = build_graph(wall, FIELD_MIN, FIELD_MAX, params(footprint_radius=0.45,
                                                          safety_margin=0.05))
    assert wide.params.inflation_cubes == (3, 0)
    assert not wide.free[mid] and not wide.edges[:, 7, 10, 5].any()


def test_a_point_in_the_corridor_cuts_the_diagonal_edge_but_not_a_far_one() -> None:
    a = (10, 10, 5)
    point = centre(11, 10, 5)[None]  # beside the diagonal (10,10) -> (11,11)
    g = build_graph(np.vstack([FAR, point]), FIELD_MIN, FIELD_MAX,
                    params(occupied_threshold=5))
    assert g.viable[11, 10, 5]  # below the cube threshold, so a node
    assert not g.edges[4][a]  # (+1, +1): its corridor holds the point
    assert g.edges[2][a]  # (0, +1) corridor is cubes 10 in x: clear
    thresholds = build_graph(np.vstack([FAR, point]), FIELD_MIN, FIELD_MAX,
                             params(occupied_threshold=5, corridor_threshold=2))
    assert thresholds.edges[4][a]  # fewer than 2 points in it: allowed


def test_vertical_clearance_blocks_the_cube_above_a_low_box() -> None:
    top = np.array([(x, y, 0.95) for x in np.arange(1.05, 3.0, 0.1)
                    for y in np.arange(1.05, 3.0, 0.1)])
    g = build_graph(top, FIELD_MIN, FIELD_MAX, params(vertical_clearance=0.2))
    assert not g.free[10, 10, 5]  # z 1.0..1.2: within 0.2 m of the top
    assert g.free[10, 10, 6] and g.free[10, 10, 7]  # 1.2.. and above: clear
    assert not g.edges[9][10, 10, 6]  # the down edge into the blocked cube


def test_unknown_space_can_be_occupied() -> None:
    grid = Grid.over(FIELD_MIN, FIELD_MAX, RES)
    observed = np.zeros(grid.shape, dtype=bool)
    observed[:10] = True
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params(unknown_is_occupied=True),
                    observed=observed)
    assert g.viable[5, 5, 5] and not g.viable[15, 5, 5]
    with pytest.raises(ValueError, match="observed"):
        build_graph(FAR, FIELD_MIN, FIELD_MAX, params(unknown_is_occupied=True))


def test_inflation_rounds_up_to_whole_cubes() -> None:
    assert params(footprint_radius=0.3, safety_margin=0.05).inflation_cubes == (2, 0)
    assert params(footprint_radius=0.4, safety_margin=0.0).inflation_cubes == (2, 0)
    assert params(footprint_radius=0.41, vertical_clearance=0.3).inflation_cubes == (3, 2)


def test_errors_say_what_is_wrong() -> None:
    with pytest.raises(EmptyCloud, match="empty"):
        build_graph(np.empty((0, 3)), FIELD_MIN, FIELD_MAX, params())
    with pytest.raises(EmptyCloud, match="inside the field"):
        build_graph(np.array([[9.0, 9.0, 9.0]]), FIELD_MIN, FIELD_MAX, params())
    with pytest.raises(ResolutionTooSmall, match="cubes"):
        build_graph(FAR, FIELD_MIN, (2000.0, 2000.0, 100.0), params(resolution=0.01))
    with pytest.raises(ResolutionTooSmall, match="> 0"):
        params(resolution=0.0)
    with pytest.raises(InvalidBounds, match="below the maximum"):
        build_graph(FAR, FIELD_MAX, FIELD_MIN, params())


def test_an_observed_map_with_no_point_in_the_field_is_free_space() -> None:
    """The depth camera saw nothing to avoid (a start pad facing open floor): the graph
    is free space bounded by the walls, floor and ceiling alone, whether the map holds no
    point or only points beyond the field; a cloud given offline still has to hold one."""
    gp = params(footprint_radius=0.35, safety_margin=0.05, vertical_clearance=0.2)
    n, m = gp.inflation_cubes
    for cloud in (np.empty((0, 3)), np.array([[9.0, 9.0, 9.0]])):
        g = build_graph(cloud, FIELD_MIN, FIELD_MAX, gp, empty_is_free=True)
        assert not g.counts.any()
        nx, ny, nz = g.grid.shape
        i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
        # free: every cube whose footprint's box stays inside the field, nothing else
        inside = ((i >= n) & (i < nx - n) & (j >= n) & (j < ny - n) & (k >= max(m, 1))
                  & (k < nz - max(m, 1)))
        assert np.array_equal(g.free, inside)
        across = plan(g, (0.5, 0.5, 1.0), (3.5, 3.5, 1.0))
        assert len(across.points) == 2  # nothing in the way: one straight leg
        with pytest.raises(EmptyCloud):
            build_graph(cloud, FIELD_MIN, FIELD_MAX, gp)
    # the camera then sees a wall: the update from free space is the full build's graph
    wall = np.array([(2.05, y, z) for y in np.arange(0.05, 3.0, 0.1)
                     for z in np.arange(0.05, 2.0, 0.1)])
    free = build_graph(np.empty((0, 3)), FIELD_MIN, FIELD_MAX, gp, empty_is_free=True)
    updated, cubes = update_graph(free, count_points(wall, free.grid))
    assert cubes > 0 and _same(updated, build_graph(wall, FIELD_MIN, FIELD_MAX, gp))
    assert len(plan(updated, (0.5, 1.0, 1.0), (3.5, 1.0, 1.0)).points) > 2  # round it


def test_the_cache_keeps_an_empty_map_apart(tmp_path) -> None:  # type: ignore[no-untyped-def]
    empty = np.empty((0, 3))
    assert (cache_key(empty, FIELD_MIN, FIELD_MAX, params(), empty_is_free=True)
            != cache_key(empty, FIELD_MIN, FIELD_MAX, params()))
    free, _ = cached_graph(empty, FIELD_MIN, FIELD_MAX, params(), tmp_path, empty_is_free=True)
    assert free.free.any()
    with pytest.raises(EmptyCloud):  # not read back from the free graph's file
        cached_graph(empty, FIELD_MIN, FIELD_MAX, params(), tmp_path)


def test_the_cache_returns_the_same_graph_and_keys_on_every_input(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cloud = np.vstack([FAR, centre(10, 10, 5)[None]])
    first, hit1 = cached_graph(cloud, FIELD_MIN, FIELD_MAX, params(), tmp_path)
    again, hit2 = cached_graph(cloud, FIELD_MIN, FIELD_MAX, params(), tmp_path)
    assert (hit1, hit2) == (False, True)
    assert np.array_equal(first.edges, again.edges) and np.array_equal(first.free, again.free)
    assert again.grid == first.grid
    base = cache_key(cloud, FIELD_MIN, FIELD_MAX, params())
    assert cache_key(cloud + 0.01, FIELD_MIN, FIELD_MAX, params()) != base
    assert cache_key(cloud, FIELD_MIN, (4.0, 4.0, 2.2), params()) != base
    assert cache_key(cloud, FIELD_MIN, FIELD_MAX, params(safety_margin=0.1)) != base
    assert math.isclose(first.grid.resolution, RES)


def test_walls_floor_and_ceiling_keep_the_footprint_away() -> None:
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params(footprint_radius=0.35, safety_margin=0.05,
                                                      vertical_clearance=0.4))
    n, m = g.params.inflation_cubes
    assert (n, m) == (2, 2)
    assert g.viable[1, 10, 5] and not g.free[1, 10, 5]  # 0.3 m from the west wall
    assert g.free[2, 10, 5]  # 0.5 m: the footprint's box reaches the wall, not beyond
    assert not g.free[18, 10, 5] and g.free[17, 10, 5]  # east wall, same rule
    assert not g.free[10, 10, 1] and g.free[10, 10, 2]  # floor: 0.3 m vs 0.5 m
    assert not g.free[10, 10, 8] and g.free[10, 10, 7]  # ceiling


def test_no_viable_cube_nearer_the_ceiling_than_its_clearance() -> None:
    # 2 m ceiling, 0.4 m clearance: centres up to 1.6 m (1.5 m, k=7) are viable, 1.7 m not
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params(ceiling_clearance=0.4))
    assert g.viable[10, 10, 7] and not g.viable[10, 10, 8]
    assert not g.edges[(slice(None), 10, 10, 8)].any()
    assert build_graph(FAR, FIELD_MIN, FIELD_MAX, params()).viable[10, 10, 8]  # without it
    centres_z = (np.nonzero(g.viable)[2] + 0.5) * RES
    assert centres_z.max() <= FIELD_MAX[2] - 0.4


def test_no_viable_cube_above_the_planning_altitude() -> None:
    # max_altitude 1.0 m: centres at 0.9 m (k=4) viable, 1.1 m (k=5) not; a 0.6 m box is
    # still flown over, a 1.2 m one no more
    low = np.array([(x, y, z) for x in np.arange(1.05, 3.0, 0.1) for y in np.arange(0.05, 4.0, 0.1)
                    for z in (0.05, 0.35, 0.55)])
    g = build_graph(low, FIELD_MIN, FIELD_MAX, params(max_altitude=1.0, vertical_clearance=0.2))
    assert g.viable[10, 10, 4] and not g.viable[10, 10, 5]
    assert g.free[10, 10, 4]  # over the 0.6 m box
    high = np.vstack([low, low + [0.0, 0.0, 0.6]])  # a 1.2 m wall across the field
    over = build_graph(high, FIELD_MIN, FIELD_MAX, params(vertical_clearance=0.2))
    assert over.free[10, 10, 7]  # unbounded: over it at 1.5 m
    g = build_graph(high, FIELD_MIN, FIELD_MAX, params(max_altitude=1.0, vertical_clearance=0.2))
    assert not g.free[10, 10, :].any()  # bounded: no way over it


def test_no_viable_cube_below_the_floor_altitude() -> None:
    # min_altitude 0.5 m: centres at 0.5 m (k=2) viable, 0.3 m (k=1) not, so no plan ducks
    # under anything lower than flight control flies
    g = build_graph(FAR, FIELD_MIN, FIELD_MAX, params(min_altitude=0.5))
    assert g.viable[10, 10, 2] and not g.viable[10, 10, 1]
    assert build_graph(FAR, FIELD_MIN, FIELD_MAX, params()).viable[10, 10, 1]  # without it


def _same(a, b) -> bool:  # type: ignore[no-untyped-def]
    return bool(np.array_equal(a.viable, b.viable) and np.array_equal(a.free, b.free)
                and np.array_equal(a.edges, b.edges) and np.array_equal(a.counts, b.counts))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), added=st.integers(1, 30), removed=st.integers(0, 5),
       radius=st.sampled_from([0.0, 0.2, 0.35]), clearance=st.sampled_from([0.0, 0.2]),
       occupied=st.integers(0, 2), corridor=st.integers(1, 3),
       ceiling=st.sampled_from([0.0, 0.4]), top=st.sampled_from([math.inf, 1.0]),
       bottom=st.sampled_from([0.0, 0.5]))
def test_an_updated_graph_is_the_graph_a_full_build_gives(  # type: ignore[no-untyped-def]
        seed, added, removed, radius, clearance, occupied, corridor, ceiling, top,
        bottom) -> None:
    """Points added anywhere (inside, near the walls, beside full cubes) and removed: the
    update recomputes a block only, and the graph is the full build's, cube for cube."""
    rng = np.random.default_rng(seed)
    gp = params(footprint_radius=radius, vertical_clearance=clearance,
                occupied_threshold=occupied, corridor_threshold=corridor,
                ceiling_clearance=ceiling, max_altitude=top, min_altitude=bottom)
    before = rng.uniform(FIELD_MIN, FIELD_MAX, (60, 3))
    after = np.vstack([before[removed:], rng.uniform(FIELD_MIN, FIELD_MAX, (added, 3)),
                       before[:added] + rng.normal(0.0, 0.1, (added, 3))])
    old = build_graph(before, FIELD_MIN, FIELD_MAX, gp)
    updated, _ = update_graph(old, count_points(after, old.grid))
    assert _same(updated, build_graph(after, FIELD_MIN, FIELD_MAX, gp))


def test_points_added_to_full_cubes_change_nothing_and_a_new_point_a_block_only() -> None:
    gp = params(footprint_radius=0.35)  # 2 cubes of inflation
    wall = np.array([(2.05, y, z) for y in np.arange(0.05, 4.0, 0.1)
                     for z in np.arange(0.05, 2.0, 0.1)])
    old = build_graph(wall, FIELD_MIN, FIELD_MAX, gp)
    # the camera sees more of the wall: new voxels, in cubes that already held points
    denser = np.vstack([wall, wall + (0.1, 0.0, 0.0)])
    same, cubes = update_graph(old, count_points(denser, old.grid))
    assert cubes == 0 and _same(same, build_graph(denser, FIELD_MIN, FIELD_MAX, gp))
    # a new obstacle point: only the block its footprint reaches, +1 cube, is recomputed
    pillar = np.vstack([wall, [[0.9, 0.9, 1.0]]])
    new, cubes = update_graph(old, count_points(pillar, old.grid))
    assert cubes == 7 * 7 * 3  # (1 + 2 * (2 + 1)) cubes across, (1 + 2 * (0 + 1)) high
    assert _same(new, build_graph(pillar, FIELD_MIN, FIELD_MAX, gp))
    assert not new.free[4, 4, 5] and old.free[4, 4, 5]
