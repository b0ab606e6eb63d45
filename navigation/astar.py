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
Int32Array = npt.NDArray[np.int32]
CHUNK_EXPANSIONS = 20_000  # expansions between two looks at the clock (time limits)
LINE_SAMPLES_PER_CUBE = 8  # line-of-sight samples per cube side


class SearchStatus(IntEnum):
    FOUND = 0
    EXHAUSTED = 1  # no path: every reachable cube was closed
    LIMIT = 2  # stopped at the expansion limit of this call


@njit(cache=True)
def _heap_push(hn: Int32Array, hk: FloatArray, pos: Int32Array, size: int, node: int,
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
def _heap_pop(hn: Int32Array, hk: FloatArray, pos: Int32Array, size: int
              ) -> tuple[int, int]:
    top = hn[0]
    pos[top] = -2  # closed
    size -= 1
    if size > 0:
        node = hn[size]
        key = hk[size]
        # Floyd's sift-down: the hole goes down the smaller children to the bottom, then
        # the last entry comes up while its parent's key is not smaller. It lands where the
        # textbook sift-down puts it (above every key >= its own on that path): the same
        # heap, with one comparison per level fewer.
        i = 0
        c = 1
        while c < size:
            if c + 1 < size and hk[c + 1] < hk[c]:
                c += 1
            hn[i] = hn[c]
            hk[i] = hk[c]
            pos[hn[i]] = i
            i = c
            c = 2 * i + 1
        while i > 0:
            parent = (i - 1) >> 1
            if hk[parent] < key:
                break
            hn[i] = hn[parent]
            hk[i] = hk[parent]
            pos[hn[i]] = i
            i = parent
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
def _search(bits: npt.NDArray[np.uint16], offsets: IntArray, ny: int, nz: int, res: float,
            start: int, goal: int, g: FloatArray, parent: Int32Array, hn: Int32Array,
            hk: FloatArray, pos: Int32Array, touched: Int32Array, state: IntArray,
            max_expansions: int, kind: int) -> int:
    """Run A* for at most ``max_expansions`` expansions. ``start >= 0`` begins a search from
    that cube, after resetting the cubes the previous search touched; ``start < 0`` goes on
    with the open set in (hn, hk, pos, state[0] = size). ``pos[c]``: -1 unseen, -2 closed,
    else heap index. ``state`` = [heap size, expansions so far, best cube (the goal once
    found, else the closed cube nearest it), cubes touched]; ``touched[:state[3]]``: the
    cubes whose g was set. Edge d of a cube joins it to the cube ``offsets[d]`` away, at
    the Euclidean distance between the centres; neighbours are found by index arithmetic,
    without dividing (an edge never leaves the grid)."""
    nyz = ny * nz
    n_dir = offsets.shape[0]
    di = np.empty(n_dir, dtype=np.int64)
    dj = np.empty(n_dir, dtype=np.int64)
    dk = np.empty(n_dir, dtype=np.int64)
    steps = np.empty(n_dir, dtype=np.int64)
    costs = np.empty(n_dir, dtype=np.float64)
    for d in range(n_dir):
        di[d] = offsets[d, 0]
        dj[d] = offsets[d, 1]
        dk[d] = offsets[d, 2]
        steps[d] = di[d] * nyz + dj[d] * nz + dk[d]
        costs[d] = math.sqrt(float(di[d] * di[d] + dj[d] * dj[d] + dk[d] * dk[d])) * res
    gx = goal // nyz
    gy = (goal - gx * nyz) // nz
    gz = goal - gx * nyz - gy * nz
    if start >= 0:
        for i in range(state[3]):
            t = touched[i]
            g[t] = np.inf
            parent[t] = -1
            pos[t] = -1
        g[start] = 0.0
        touched[0] = start
        state[0] = _heap_push(hn, hk, pos, 0, start, 0.0)
        state[1] = 0
        state[2] = start
        state[3] = 1
        best_h = np.inf
    else:
        bx = state[2] // nyz
        by = (state[2] - bx * nyz) // nz
        best_h = _h(kind, bx - gx, by - gy, state[2] - bx * nyz - by * nz - gz, res)
    best_c = state[2]
    size = state[0]
    n_touched = state[3]
    status = 1
    done = 0
    while size > 0:
        if done >= max_expansions:
            status = 2
            break
        cur, size = _heap_pop(hn, hk, pos, size)
        done += 1
        if cur == goal:
            best_c = cur
            status = 0
            break
        cx = cur // nyz
        cy = (cur - cx * nyz) // nz
        dx = cx - gx
        dy = cy - gy
        dz = cur - cx * nyz - cy * nz - gz
        h = _h(kind, dx, dy, dz, res)
        if h < best_h:
            best_h = h
            best_c = cur
        gc = g[cur]
        b = np.int64(bits[cur])
        for d in range(n_dir):
            if (b >> d) == 0:
                break
            if not (b >> d) & 1:
                continue
            nb = cur + steps[d]
            ng = gc + costs[d]
            gn = g[nb]
            if ng < gn and pos[nb] != -2:  # improved and not closed
                if gn == np.inf:
                    touched[n_touched] = nb
                    n_touched += 1
                g[nb] = ng
                parent[nb] = cur
                hb = _h(kind, dx + di[d], dy + dj[d], dz + dk[d], res)
                size = _heap_push(hn, hk, pos, size, nb, ng + hb)
    state[0] = size
    state[1] += done
    state[2] = best_c
    state[3] = n_touched
    return status


@njit(cache=True)
def _trace(parent: Int32Array, end: int) -> IntArray:
    """The cubes from the search's start to ``end``, following the parents."""
    n = 1
    c = end
    while parent[c] >= 0:
        c = parent[c]
        n += 1
    path = np.empty(n, dtype=np.int64)
    c = end
    for i in range(n - 1, -1, -1):
        path[i] = c
        c = parent[c]
    return path


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
    if n == 0:
        return keep
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


class Workspace:
    """The search's arrays for a grid of ``size`` cubes, reused from one search to the next:
    a search first resets the cubes the previous one touched, so that reuse costs no
    allocation and no pass over the grid. One search at a time. Cube indices are int32
    (half the memory the search walks through; a grid holds at most
    :data:`~navigation.voxel_graph.MAX_CUBES` < 2**31 cubes)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.g = np.full(size, np.inf)
        self.parent = np.full(size, -1, dtype=np.int32)
        self.pos = np.full(size, -1, dtype=np.int32)
        self.hn = np.empty(size, dtype=np.int32)
        self.hk = np.empty(size)
        self.touched = np.empty(size, dtype=np.int32)
        self.state = np.zeros(4, dtype=np.int64)  # see _search


_STATUS = tuple(SearchStatus)  # by value: no enum lookup per query
_NO_LIMIT = int(np.iinfo(np.int64).max)
_NO_CELLS = np.empty(0, dtype=np.int64)
_NO_CELLS.flags.writeable = False


def astar(graph: VoxelGraph, start: int, goal: int, *, max_expansions: int | None = None,
          time_limit_s: float | None = None, heuristic: Heuristic = Heuristic.EUCLIDEAN,
          workspace: Workspace | None = None) -> SearchResult:
    """A* between two cubes (flat indices). Returns FOUND with the optimal path, EXHAUSTED
    (empty path), or LIMIT with the path to the closed cube nearest the goal. No checks on
    start and goal beyond being cubes of the grid (see :func:`plan`). ``workspace``: reuse
    its arrays (no allocation but the path's)."""
    grid = graph.grid
    n = grid.size
    ws = workspace if workspace is not None else Workspace(n)
    if ws.size != n:
        raise ValueError(f"workspace for {ws.size} cubes, graph has {n}")
    if not (0 <= start < n and 0 <= goal < n):
        raise IndexError(f"start {start} and goal {goal} must be cubes of the grid "
                         f"(0 .. {n - 1})")
    _, ny, nz = grid.shape
    limit = _NO_LIMIT if max_expansions is None else max_expansions
    state, kind = ws.state, int(heuristic)

    def search(begin: int, chunk: int) -> int:
        return _search(graph.edge_bits, OFFSETS, ny, nz, grid.resolution, begin, goal, ws.g,
                       ws.parent, ws.hn, ws.hk, ws.pos, ws.touched, state, chunk, kind)

    if time_limit_s is None:
        code = search(start, limit)
    else:  # in chunks, looking at the clock between two
        deadline = time.perf_counter() + time_limit_s
        code = search(start, min(limit, CHUNK_EXPANSIONS))
        while (code == SearchStatus.LIMIT and state[1] < limit
               and time.perf_counter() < deadline):
            code = search(-1, min(limit - int(state[1]), CHUNK_EXPANSIONS))
    expansions = int(state[1])
    if code == SearchStatus.EXHAUSTED:
        return SearchResult(_NO_CELLS, math.inf, expansions, SearchStatus.EXHAUSTED)
    end = int(state[2])  # the goal when found
    return SearchResult(_trace(ws.parent, end), float(ws.g[end]), expansions, _STATUS[code])


def _point(point: npt.ArrayLike) -> FloatArray:
    """A map point [m] as 3 float64 (one compiled specialisation of the kernels)."""
    return np.asarray(point, dtype=np.float64).reshape(3)


def _as_points(points: npt.ArrayLike) -> FloatArray:
    """(N, 3) float64 map points [m], contiguous."""
    return np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)


def _rounded(point: FloatArray) -> list[float]:
    """A point for a message: metres, to the millimetre."""
    return np.round(point, 3).tolist()


def shortcut(graph: VoxelGraph, points: npt.ArrayLike) -> FloatArray:
    """The line-of-sight pass: from each kept waypoint, jump to the farthest later one
    whose straight segment stays in free cubes. Ends are kept. A new array."""
    p = _as_points(points)
    return p[_shortcut(p, graph.free, np.asarray(graph.grid.origin), graph.grid.resolution,
                       LINE_SAMPLES_PER_CUBE)]


def segment_free(graph: VoxelGraph, a: npt.ArrayLike, b: npt.ArrayLike) -> bool:
    """Whether the straight segment a -> b stays in free cubes (the shortcut's test)."""
    return bool(_line_free(graph.free, np.asarray(graph.grid.origin), graph.grid.resolution,
                           _point(a), _point(b), LINE_SAMPLES_PER_CUBE))


def path_length(points: npt.ArrayLike) -> float:
    """The length [m] of the polyline through (N, 3) points; 0 for fewer than two."""
    return float(np.linalg.norm(np.diff(_as_points(points), axis=0), axis=1).sum())


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
    [m] (the first in index order among equals); None when there is none. Raises
    OutOfBounds outside the grid."""
    found = _snap(graph, _point(point), radius)
    return None if found is None else found[0]


def _snap(graph: VoxelGraph, p: FloatArray, radius: float) -> tuple[int, bool] | None:
    """:func:`snap`'s cube and whether it holds ``p``; None when there is none."""
    grid = graph.grid
    cell = grid.cell_of(p)[0]
    if not grid.inside(cell[None])[0]:
        raise OutOfBounds(f"{_rounded(p)} m is outside the field")
    if graph.free[tuple(cell)]:
        return int(grid.flat(cell[None])[0]), True
    r = math.ceil(radius / grid.resolution)  # every centre within radius is in this block
    lo = np.maximum(cell - r, 0)
    hi = np.minimum(cell + r + 1, np.asarray(grid.shape))
    block = graph.free[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    cand = np.argwhere(block) + lo
    if len(cand) == 0:
        return None
    d = np.linalg.norm(grid.center(cand) - p, axis=1)
    i = int(np.argmin(d))  # first of equals: argwhere's order, deterministic
    if d[i] > radius:
        return None
    return int(grid.flat(cand[i][None])[0]), False


def plan(graph: VoxelGraph, start: npt.ArrayLike, goal: npt.ArrayLike, *,
         snap_radius: float = 0.0, max_expansions: int | None = None,
         time_limit_s: float | None = None, partial: bool = False,
         use_shortcut: bool = True, heuristic: Heuristic = Heuristic.EUCLIDEAN,
         workspace: Workspace | None = None) -> PlannedPath:
    """Plan from ``start`` to ``goal`` [m, map frame]. Waypoints are the cube centres
    between the exact start and goal points (each kept when it lies in its end cube, else
    that cube's centre), shortened by :func:`shortcut`. Raises OutOfBounds, StartOccupied,
    GoalOccupied, NoPathFound or PlanningTimedOut (whose ``partial`` is the path to the
    closed cube nearest the goal when ``partial``)."""
    s_pt, g_pt = _point(start), _point(goal)
    s_found = _snap(graph, s_pt, snap_radius)
    if s_found is None:
        raise StartOccupied(f"start {_rounded(s_pt)} m is in or too close to an obstacle "
                            "(no free cube there)")
    g_found = _snap(graph, g_pt, snap_radius)
    if g_found is None:
        raise GoalOccupied(f"goal {_rounded(g_pt)} m is in or too close to an obstacle "
                           "(no free cube there)")
    (s, s_inside), (g, g_inside) = s_found, g_found
    result = astar(graph, s, g, max_expansions=max_expansions, time_limit_s=time_limit_s,
                   heuristic=heuristic, workspace=workspace)
    if result.status is SearchStatus.EXHAUSTED:
        raise NoPathFound(f"no path from {_rounded(s_pt)} to {_rounded(g_pt)} m: the goal is "
                          f"not connected to the start ({result.expansions} cubes searched)")
    points = graph.grid.center(graph.grid.unflat(result.cells))
    if result.status is SearchStatus.LIMIT:
        best = shortcut(graph, points) if use_shortcut else points
        raise PlanningTimedOut(
            f"search stopped after {result.expansions} expansions without reaching the goal",
            partial=best if partial else None)
    if s_inside:
        points[0] = s_pt
    if g_inside:
        points[-1] = g_pt
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
