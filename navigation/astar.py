"""A* on the voxel graph (seed 003, sec. 3.3.2): optimal, with the Euclidean heuristic
(the seed's; :attr:`Heuristic.OCTILE`, tighter for the graph's moves, is the option).

Pure: numpy and numba (the inner loop is compiled; no runtime imports). The search keeps
an indexed binary heap (decrease-key, so the heap never holds more than one entry per
cube) and a closed set; the Euclidean distance between cube centres is admissible and
consistent for the graph's Euclidean edge costs, so the first time the goal is popped its
cost is optimal.

:func:`plan` is what the path finder calls: it snaps start and goal to their cubes, checks
them as the seed does (:class:`~navigation.errors.StartOccupied`,
:class:`~navigation.errors.GoalOccupied`), searches within an optional expansion or time
limit (:class:`~navigation.errors.PlanningTimedOut`, with the best partial path when asked:
the closed cube nearest the goal), and runs the line-of-sight shortcut pass
(:func:`shortcut`): a waypoint is dropped when the straight segment that skips it stays in
free cubes (sampled every ``res / 8``), so the shortened path is as collision-free as the
graph's edges.

Map frame (ENU), metres.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
import numpy.typing as npt
from numba import njit

from navigation.errors import (
    GoalOccupied,
    NoPathFound,
    OutOfBounds,
    PlanningTimedOut,
    StartOccupied,
)
from navigation.voxel_graph import OFFSETS, VoxelGraph

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
CHUNK_EXPANSIONS = 20_000  # expansions between two looks at the clock (time limits)
LINE_SAMPLES_PER_CUBE = 8  # line-of-sight samples per cube side


class SearchStatus(IntEnum):
    FOUND = 0
    EXHAUSTED = 1  # no path: every reachable cube was closed
    LIMIT = 2  # stopped at the expansion limit of this call


@njit(cache=True)
def _heap_push(hn: IntArray, hk: FloatArray, pos: IntArray, size: int, node: int,
               key: float) -> int:
    i = pos[node]
    if i < 0:
        i = size
        size += 1
    hn[i] = node
    hk[i] = key
    while i > 0:  # sift up
        parent = (i - 1) >> 1
        if hk[parent] <= key:
            break
        hn[i] = hn[parent]
        hk[i] = hk[parent]
        pos[hn[i]] = i
        i = parent
    hn[i] = node
    hk[i] = key
    pos[node] = i
    return size


@njit(cache=True)
def _heap_pop(hn: IntArray, hk: FloatArray, pos: IntArray, size: int) -> tuple[int, int]:
    top = hn[0]
    pos[top] = -2  # closed
    size -= 1
    if size > 0:
        node = hn[size]
        key = hk[size]
        i = 0
        while True:  # sift down
            c = 2 * i + 1
            if c >= size:
                break
            if c + 1 < size and hk[c + 1] < hk[c]:
                c += 1
            if hk[c] >= key:
                break
            hn[i] = hn[c]
            hk[i] = hk[c]
            pos[hn[i]] = i
            i = c
        hn[i] = node
        hk[i] = key
        pos[node] = i
    return top, size


class Heuristic(IntEnum):
    """Admissible, consistent heuristics for the graph's moves (both keep A* optimal)."""

    EUCLIDEAN = 0  # the seed's: straight-line distance between the centres
    OCTILE = 1  # octile in the horizontal plane + |dz|: exact on an empty grid, tighter


@njit(cache=True)
def _h(kind: int, dx: int, dy: int, dz: int, res: float) -> float:
    if kind == 0:
        return res * math.sqrt(dx * dx + dy * dy + dz * dz)
    ax = abs(dx)
    ay = abs(dy)
    lo = min(ax, ay)
    return res * (max(ax, ay) - lo + math.sqrt(2.0) * lo + abs(dz))


@njit(cache=True)
def _search(bits: npt.NDArray[np.uint16], nx: int, ny: int, nz: int, steps: IntArray,
            costs: FloatArray, res: float, goal: int, g: FloatArray, parent: IntArray,
            hn: IntArray, hk: FloatArray, pos: IntArray, touched: IntArray, state: IntArray,
            best: FloatArray, max_expansions: int, kind: int) -> int:
    """Run A* from the open set in (hn, hk, pos, state[0] = size) for at most
    ``max_expansions`` expansions. ``pos[c]``: -1 unseen, -2 closed, else heap index.
    ``state`` = [heap size, expansions so far, best cube, cubes touched]; ``best[0]`` the
    best cube's heuristic; ``touched[:state[3]]``: the cubes whose g was set."""
    size = state[0]
    gx = goal // (ny * nz)
    gy = (goal // nz) % ny
    gz = goal % nz
    done = 0
    n_dir = steps.shape[0]
    while size > 0:
        if done >= max_expansions:
            state[0] = size
            return 2
        cur, size = _heap_pop(hn, hk, pos, size)
        done += 1
        state[1] += 1
        if cur == goal:
            state[0] = size
            state[2] = cur
            best[0] = 0.0
            return 0
        cx = cur // (ny * nz)
        cy = (cur // nz) % ny
        cz = cur % nz
        h = _h(kind, cx - gx, cy - gy, cz - gz, res)
        if h < best[0]:
            best[0] = h
            state[2] = cur
        gc = g[cur]
        b = bits[cur]
        for d in range(n_dir):
            if not (b >> d) & 1:
                continue
            nb = cur + steps[d]
            if pos[nb] == -2:
                continue
            ng = gc + costs[d]
            if ng < g[nb]:
                if g[nb] == np.inf:
                    touched[state[3]] = nb
                    state[3] += 1
                g[nb] = ng
                parent[nb] = cur
                bx = nb // (ny * nz)
                by = (nb // nz) % ny
                bz = nb % nz
                hb = _h(kind, bx - gx, by - gy, bz - gz, res)
                size = _heap_push(hn, hk, pos, size, nb, ng + hb)
    state[0] = size
    return 1


@njit(cache=True)
def _line_free(free: npt.NDArray[np.bool_], origin: FloatArray, res: float, a: FloatArray,
               b: FloatArray, per_cube: int) -> bool:
    length = math.sqrt((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2)
    n = math.ceil(length / res * per_cube) + 1
    for s in range(n + 1):
        t = s / n
        i = math.floor((a[0] + t * (b[0] - a[0]) - origin[0]) / res)
        j = math.floor((a[1] + t * (b[1] - a[1]) - origin[1]) / res)
        k = math.floor((a[2] + t * (b[2] - a[2]) - origin[2]) / res)
        if (i < 0 or j < 0 or k < 0 or i >= free.shape[0] or j >= free.shape[1]
                or k >= free.shape[2]):
            return False
        if not free[i, j, k]:
            return False
    return True


@njit(cache=True)
def _shortcut(points: FloatArray, free: npt.NDArray[np.bool_], origin: FloatArray, res: float,
              per_cube: int) -> IntArray:
    n = points.shape[0]
    keep = np.empty(n, dtype=np.int64)
    keep[0] = 0
    count = 1
    anchor = 0
    while anchor < n - 1:
        nxt = anchor + 1
        for j in range(n - 1, anchor + 1, -1):
            if _line_free(free, origin, res, points[anchor], points[j], per_cube):
                nxt = j
                break
        keep[count] = nxt
        count += 1
        anchor = nxt
    return keep[:count]


@dataclass(frozen=True)
class SearchResult:
    """A search's cubes (flat indices, start first), cost [m] and effort."""

    cells: IntArray
    cost: float
    expansions: int
    status: SearchStatus


def _trace(parent: IntArray, end: int) -> IntArray:
    out = [end]
    while parent[out[-1]] >= 0:
        out.append(int(parent[out[-1]]))
    return np.asarray(out[::-1], dtype=np.int64)


class Workspace:
    """The search's arrays for a grid of ``size`` cubes, reused from one search to the next
    (each search resets only the cubes it touched). One search at a time."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.g = np.full(size, np.inf)
        self.parent = np.full(size, -1, dtype=np.int64)
        self.pos = np.full(size, -1, dtype=np.int64)
        self.hn = np.empty(size, dtype=np.int64)
        self.hk = np.empty(size, dtype=np.float64)
        self.touched = np.empty(size, dtype=np.int64)

    def reset(self, count: int) -> None:
        t = self.touched[:count]
        self.g[t] = np.inf
        self.parent[t] = -1
        self.pos[t] = -1


def astar(graph: VoxelGraph, start: int, goal: int, *, max_expansions: int | None = None,
          time_limit_s: float | None = None, heuristic: Heuristic = Heuristic.EUCLIDEAN,
          workspace: Workspace | None = None) -> SearchResult:
    """A* between two cubes (flat indices). Returns FOUND with the optimal path, EXHAUSTED
    (empty path), or LIMIT with the path to the closed cube nearest the goal. No checks on
    start and goal (see :func:`plan`). ``workspace``: reuse its arrays (no allocation)."""
    _, ny, nz = graph.grid.shape
    steps = (OFFSETS[:, 0] * ny * nz + OFFSETS[:, 1] * nz + OFFSETS[:, 2]).astype(np.int64)
    costs = graph.step_costs
    ws = workspace if workspace is not None else Workspace(graph.grid.size)
    if ws.size != graph.grid.size:
        raise ValueError(f"workspace for {ws.size} cubes, graph has {graph.grid.size}")
    ws.g[start] = 0.0
    ws.touched[0] = start
    state = np.array([0, 0, start, 1], dtype=np.int64)
    best = np.array([np.inf])
    state[0] = _heap_push(ws.hn, ws.hk, ws.pos, 0, start, 0.0)
    try:
        return _run(graph, ws, goal, steps, costs, state, best, max_expansions, time_limit_s,
                    heuristic)
    finally:
        ws.reset(int(state[3]))


def _run(graph: VoxelGraph, ws: Workspace, goal: int, steps: IntArray, costs: FloatArray,
         state: IntArray, best: FloatArray, max_expansions: int | None,
         time_limit_s: float | None, heuristic: Heuristic) -> SearchResult:
    nx, ny, nz = graph.grid.shape
    limit = max_expansions if max_expansions is not None else np.iinfo(np.int64).max
    deadline = None if time_limit_s is None else time.perf_counter() + time_limit_s
    while True:
        chunk = limit - int(state[1])
        if deadline is not None:
            chunk = min(chunk, CHUNK_EXPANSIONS)
        status = SearchStatus(_search(graph.edge_bits, nx, ny, nz, steps, costs,
                                      graph.grid.resolution, goal, ws.g, ws.parent, ws.hn,
                                      ws.hk, ws.pos, ws.touched, state, best, chunk,
                                      int(heuristic)))
        if status is not SearchStatus.LIMIT:
            break
        if int(state[1]) >= limit or (deadline is not None and time.perf_counter() >= deadline):
            break
    expansions = int(state[1])
    if status is SearchStatus.EXHAUSTED:
        return SearchResult(np.empty(0, dtype=np.int64), math.inf, expansions, status)
    end = goal if status is SearchStatus.FOUND else int(state[2])
    return SearchResult(_trace(ws.parent, end), float(ws.g[end]), expansions, status)


def shortcut(graph: VoxelGraph, points: npt.ArrayLike) -> FloatArray:
    """The line-of-sight pass: from each kept waypoint, jump to the farthest later one
    whose straight segment stays in free cubes. Ends are kept."""
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) <= 2:
        return p.copy()
    keep = _shortcut(p, graph.free, np.asarray(graph.grid.origin, dtype=np.float64),
                     graph.grid.resolution, LINE_SAMPLES_PER_CUBE)
    return p[keep]


def segment_free(graph: VoxelGraph, a: npt.ArrayLike, b: npt.ArrayLike) -> bool:
    """Whether the straight segment a -> b stays in free cubes (the shortcut's test)."""
    return bool(_line_free(graph.free, np.asarray(graph.grid.origin, dtype=np.float64),
                           graph.grid.resolution, np.asarray(a, dtype=np.float64),
                           np.asarray(b, dtype=np.float64), LINE_SAMPLES_PER_CUBE))


def path_length(points: npt.ArrayLike) -> float:
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


@dataclass(frozen=True)
class PlannedPath:
    """A planned path: map-frame waypoints (start first, goal last), its length [m], the
    graph path's cost before the shortcut [m], and the search's expansions."""

    points: FloatArray
    length: float
    graph_cost: float
    expansions: int
    partial: bool = False


def snap(graph: VoxelGraph, point: npt.ArrayLike, radius: float) -> int | None:
    """The free cube holding ``point``, or the nearest free cube centre within ``radius``
    [m]; None when there is none. Raises OutOfBounds outside the grid."""
    grid = graph.grid
    cell = grid.cell_of(point)[0]
    if not grid.inside(cell[None])[0]:
        raise OutOfBounds(f"{np.round(np.asarray(point, dtype=float), 3).tolist()} m is "
                          "outside the field")
    if graph.free[tuple(cell)]:
        return int(grid.flat(cell[None])[0])
    r = math.ceil(radius / grid.resolution)
    if r <= 0:
        return None
    lo = np.maximum(cell - r, 0)
    hi = np.minimum(cell + r + 1, np.asarray(grid.shape))
    block = graph.free[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    cand = np.argwhere(block) + lo
    if len(cand) == 0:
        return None
    d = np.linalg.norm(grid.center(cand) - np.asarray(point, dtype=np.float64), axis=1)
    i = int(np.argmin(d))  # first of equals: argwhere's order, deterministic
    if d[i] > radius:
        return None
    return int(grid.flat(cand[i][None])[0])


def plan(graph: VoxelGraph, start: npt.ArrayLike, goal: npt.ArrayLike, *,
         snap_radius: float = 0.0, max_expansions: int | None = None,
         time_limit_s: float | None = None, partial: bool = False,
         use_shortcut: bool = True, heuristic: Heuristic = Heuristic.EUCLIDEAN,
         workspace: Workspace | None = None) -> PlannedPath:
    """Plan from ``start`` to ``goal`` [m, map frame]. Waypoints are the cube centres
    between the exact start and goal points, shortened by :func:`shortcut`. Raises
    OutOfBounds, StartOccupied, GoalOccupied, NoPathFound or PlanningTimedOut (whose
    ``partial`` is the path to the closed cube nearest the goal when ``partial``)."""
    s_pt = np.asarray(start, dtype=np.float64).reshape(3)
    g_pt = np.asarray(goal, dtype=np.float64).reshape(3)
    s = snap(graph, s_pt, snap_radius)
    if s is None:
        raise StartOccupied(f"start {np.round(s_pt, 3).tolist()} m is in or too close to an "
                            "obstacle (no free cube there)")
    g = snap(graph, g_pt, snap_radius)
    if g is None:
        raise GoalOccupied(f"goal {np.round(g_pt, 3).tolist()} m is in or too close to an "
                           "obstacle (no free cube there)")
    result = astar(graph, s, g, max_expansions=max_expansions, time_limit_s=time_limit_s,
                   heuristic=heuristic, workspace=workspace)
    if result.status is SearchStatus.EXHAUSTED:
        raise NoPathFound(f"no path from {np.round(s_pt, 3).tolist()} to "
                          f"{np.round(g_pt, 3).tolist()} m: the goal is not connected to the "
                          f"start ({result.expansions} cubes searched)")
    centres = graph.grid.center(graph.grid.unflat(result.cells))
    if result.status is SearchStatus.LIMIT:
        best = shortcut(graph, centres) if use_shortcut else centres
        raise PlanningTimedOut(
            f"search stopped after {result.expansions} expansions without reaching the goal",
            partial=best if partial else None)
    points = centres.copy()
    points[0] = s_pt if graph.grid.flat(graph.grid.cell_of(s_pt))[0] == s else centres[0]
    points[-1] = g_pt if graph.grid.flat(graph.grid.cell_of(g_pt))[0] == g else centres[-1]
    if use_shortcut:
        points = shortcut(graph, points)
    return PlannedPath(points, path_length(points), result.cost, result.expansions)


__all__ = [
    "Heuristic",
    "PlannedPath",
    "SearchResult",
    "SearchStatus",
    "Workspace",
    "astar",
    "path_length",
    "plan",
    "segment_free",
    "shortcut",
    "snap",
]
