"""The seed's voxel graph of the free space, built from a point cloud (seed 003, sec. 3.3.2).

Pure and vectorised (numpy; no Python loop over cubes). The rules, each in one place:

- the field box is divided into cubes of side ``resolution`` from the field's minimum
  corner (a fixed origin), each identified by its centre;
- points outside the field are dropped; a cloud with none left raises EmptyCloud, unless
  the caller says it is an observation (``empty_is_free``: the depth camera saw nothing
  to avoid in the field), which is a graph of free space;
- boundary cubes (the outer layer on every side, floor and ceiling included) are
  non-viable, and the walls, floor and ceiling beyond them count as obstacles for the
  corridors (cubes outside the field as far as the footprint reaches hold
  ``corridor_threshold`` points each), so paths keep the footprint's clearance from them;
- cubes holding more than ``occupied_threshold`` points are non-viable;
- optionally (``unknown_is_occupied``) cubes never observed are non-viable;
- beyond the seed, a planning band: cubes whose centre is nearer the ceiling than
  ``ceiling_clearance`` (the app sets flight control's ``wall_clearance``: its reach
  targets stop there), higher above the floor than ``max_altitude`` or lower than
  ``min_altitude`` (the app sets flight control's floor, ``min_altitude``) are non-viable. The
  forward depth camera sees an obstacle's face only so high; above, space is unknown and
  would count as free, so a plan "over" a tall block whose top was never seen flies into
  it. Tall obstacles are flown round, low ones over;
- each cube's neighbours are the 8 horizontal ones at the same altitude plus the ones
  directly above and below (:data:`OFFSETS`);
- an edge joins two viable neighbours if and only if the corridor between them holds
  fewer than ``corridor_threshold`` points; its cost is the Euclidean distance between
  the centres.

The corridor is the drone's footprint swept from one centre to the other, inflated the
way EGO-Planner users ask for: the horizontal radius ``footprint_radius +
safety_margin`` becomes ``n = ceil(r / res)`` cubes (``res * ceil(r / res)`` metres), the
vertical half-height ``vertical_clearance`` becomes ``m = ceil(h / res)`` cubes, and the
corridor is the box of cubes ``min(a, b) - (n, n, m)`` .. ``max(a, b) + (n, n, m)``. Points
are counted per cube, so the box count comes from a 3-D summed-area table in O(1) per edge.
Every point of a corridor's cubes is at least ``(n + 1/2) res`` (horizontally, Chebyshev)
from the segment's ends: the box over-approximates the swept disc, never under.

A cube is *free* when it is viable and its own box (``cube +- (n, n, m)``) holds fewer than
``corridor_threshold`` points: the cubes a path may pass through (start, goal and the
line-of-sight check of :mod:`navigation.astar`). Every edge joins two free cubes.

Map frame (ENU), metres.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navigation.errors import EmptyCloud, InvalidBounds, ResolutionTooSmall

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Neighbour offsets (i, j, k): 8 horizontal, then up and down. Edge d of cube c joins c
#: and c + OFFSETS[d]; OPPOSITE[d] is the same edge seen from the other end.
OFFSETS: npt.NDArray[np.int64] = np.array(
    [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0),
     (1, 1, 0), (1, -1, 0), (-1, 1, 0), (-1, -1, 0),
     (0, 0, 1), (0, 0, -1)], dtype=np.int64)
OPPOSITE: npt.NDArray[np.int64] = np.array([1, 0, 3, 2, 7, 6, 5, 4, 9, 8], dtype=np.int64)
MAX_CUBES = 50_000_000  # beyond this the grid does not fit in memory: resolution too small
GRAPH_VERSION = 2  # bump when the rules change: old cache files stop matching


@dataclass(frozen=True)
class GraphParams:
    """How a cloud becomes a graph. Metres; thresholds in points."""

    resolution: float  # m, cube side
    occupied_threshold: int = 2  # a cube with more points than this is non-viable
    corridor_threshold: int = 1  # an edge needs fewer points than this in its corridor
    footprint_radius: float = 0.35  # m, the drone's horizontal half-width
    safety_margin: float = 0.05  # m, added to the footprint
    vertical_clearance: float = 0.2  # m, half-height of the corridor
    unknown_is_occupied: bool = False  # unobserved cubes are non-viable (needs ``observed``)
    ceiling_clearance: float = 0.0  # m, viable cube centres stay this far below the grid's top
    max_altitude: float = math.inf  # m above the floor, viable cube centres stay at or below
    min_altitude: float = 0.0  # m above the floor, viable cube centres stay at or above

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise ResolutionTooSmall(f"resolution {self.resolution} m: must be > 0")
        if self.occupied_threshold < 0 or self.corridor_threshold < 1:
            raise ValueError(
                f"GraphParams: occupied_threshold {self.occupied_threshold} must be >= 0 and "
                f"corridor_threshold {self.corridor_threshold} >= 1")
        for name in ("footprint_radius", "safety_margin", "vertical_clearance",
                     "ceiling_clearance", "max_altitude", "min_altitude"):
            value = getattr(self, name)
            if not (value >= 0.0 and (math.isfinite(value) or name == "max_altitude")):
                raise ValueError(f"GraphParams.{name}: {value} m must be >= 0")

    @property
    def inflation_cubes(self) -> tuple[int, int]:
        """(n, m): the corridor's horizontal and vertical half-width in cubes,
        ``ceil(r / res)`` (a tiny tolerance keeps 0.4 / 0.2 at 2, not 3)."""
        res = self.resolution
        r = self.footprint_radius + self.safety_margin
        return (math.ceil(r / res - 1e-9), math.ceil(self.vertical_clearance / res - 1e-9))


@dataclass(frozen=True)
class Grid:
    """The cube grid over the field box: origin = the field's minimum corner."""

    origin: tuple[float, float, float]  # m
    resolution: float  # m
    shape: tuple[int, int, int]  # cubes along x, y, z

    @classmethod
    def over(cls, field_min: npt.ArrayLike, field_max: npt.ArrayLike, resolution: float) -> Grid:
        lo = np.asarray(field_min, dtype=np.float64).reshape(3)
        hi = np.asarray(field_max, dtype=np.float64).reshape(3)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            raise InvalidBounds(f"field bounds {lo.tolist()} .. {hi.tolist()} m: the minimum "
                                "must be below the maximum on every axis")
        if not (math.isfinite(resolution) and resolution > 0.0):
            raise ResolutionTooSmall(f"resolution {resolution} m: must be > 0")
        # a field side that is a multiple of the resolution must not gain a cube to rounding
        shape = np.ceil((hi - lo) / resolution - 1e-9).astype(np.int64)
        cubes = int(np.prod(shape.astype(np.float64)))
        if cubes > MAX_CUBES:
            raise ResolutionTooSmall(
                f"resolution {resolution} m gives {cubes} cubes for the field "
                f"{(hi - lo).tolist()} m; at most {MAX_CUBES} (use a coarser resolution)")
        if np.any(shape < 3):
            raise ResolutionTooSmall(
                f"resolution {resolution} m gives {shape.tolist()} cubes for the field "
                f"{(hi - lo).tolist()} m; each axis needs at least 3 (boundary + inside)")
        return cls((float(lo[0]), float(lo[1]), float(lo[2])), float(resolution),
                   (int(shape[0]), int(shape[1]), int(shape[2])))

    @property
    def size(self) -> int:
        return self.shape[0] * self.shape[1] * self.shape[2]

    def cell_of(self, points: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """(N, 3) integer cube indices of map points (may be outside the grid)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return np.floor((p - np.asarray(self.origin)) / self.resolution).astype(np.int64)

    def inside(self, cells: npt.NDArray[np.int64]) -> BoolArray:
        return np.all((cells >= 0) & (cells < np.asarray(self.shape)), axis=1)

    def center(self, cells: npt.ArrayLike) -> FloatArray:
        """Map-frame centres of (N, 3) cube indices."""
        c = np.asarray(cells, dtype=np.float64).reshape(-1, 3)
        return np.asarray(self.origin) + (c + 0.5) * self.resolution

    def flat(self, cells: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        return np.ravel_multi_index(tuple(cells.T), self.shape)

    def unflat(self, index: npt.ArrayLike) -> npt.NDArray[np.int64]:
        return np.stack(np.unravel_index(np.asarray(index, dtype=np.int64), self.shape),
                        axis=-1).astype(np.int64)


@dataclass(frozen=True, eq=False)
class VoxelGraph:
    """Cubes and edges. ``edges[d, i, j, k]``: an edge from cube (i, j, k) along
    ``OFFSETS[d]`` (symmetric: the neighbour has the OPPOSITE edge)."""

    grid: Grid
    params: GraphParams
    counts: npt.NDArray[np.int32]  # points per cube
    viable: BoolArray  # the seed's viable cubes (nodes)
    free: BoolArray  # viable and clear of points for the footprint (see module docstring)
    edges: BoolArray  # (10, nx, ny, nz)

    @property
    def step_costs(self) -> FloatArray:
        """Edge cost per direction [m]: the Euclidean distance between the centres."""
        return np.linalg.norm(OFFSETS.astype(np.float64), axis=1) * self.grid.resolution

    @cached_property
    def edge_bits(self) -> npt.NDArray[np.uint16]:
        """Per cube (flat index), bit d set when edge d exists: one load per expansion."""
        bits = np.zeros(self.grid.size, dtype=np.uint16)
        for d in range(len(OFFSETS)):
            bits |= self.edges[d].reshape(-1).astype(np.uint16) << d
        return bits

    @property
    def edge_count(self) -> int:
        """Undirected edges."""
        return int(self.edges.sum()) // 2

    def neighbours(self, cell: tuple[int, int, int]) -> list[tuple[int, int, int]]:
        """The cubes joined to ``cell`` by an edge."""
        out = []
        for d in np.flatnonzero(self.edges[(slice(None), *cell)]):
            n = np.asarray(cell) + OFFSETS[d]
            out.append((int(n[0]), int(n[1]), int(n[2])))
        return out



def top_cube_centre(resolution: float, ceiling: float) -> float:
    """The highest centre of the path finder's cubes (side ``resolution``, from the floor
    up) at or below ``ceiling`` [m]."""
    return (math.floor(ceiling / resolution + 1e-9 - 0.5) + 0.5) * resolution

def count_points(points: npt.ArrayLike, grid: Grid, *,
                 empty_is_free: bool = False) -> npt.NDArray[np.int32]:
    """Points per cube; points outside the field are dropped. When none is left: raises
    EmptyCloud, or, with ``empty_is_free`` (a map the depth camera made, which saw nothing
    to avoid in the field), every count is 0: all free space."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0 and not empty_is_free:
        raise EmptyCloud("the point cloud is empty")
    p = p[np.all(np.isfinite(p), axis=1)]
    lo = np.asarray(grid.origin)
    hi = lo + np.asarray(grid.shape) * grid.resolution
    p = p[np.all((p >= lo) & (p < hi), axis=1)]
    if len(p) == 0 and not empty_is_free:
        raise EmptyCloud(f"none of the cloud's points is inside the field {lo.tolist()} .. "
                         f"{hi.tolist()} m")
    flat = grid.flat(grid.cell_of(p))
    counts = np.bincount(flat, minlength=grid.size).astype(np.int32)
    return counts.reshape(grid.shape)


def _slices(lo: npt.NDArray[np.int64], size: npt.NDArray[np.int64]) -> tuple[slice, ...]:
    return tuple(slice(int(a), int(a) + int(n)) for a, n in zip(lo, size, strict=True))


def _box_sums_over(sat: npt.NDArray[np.int64], first: npt.NDArray[np.int64],
                   last: npt.NDArray[np.int64], size: npt.NDArray[np.int64]
                   ) -> npt.NDArray[np.int64]:
    """For a block of ``size`` cells, the count over the box [cell + first, cell + last]
    of each (local indices of the summed-area table's array; every box inside it): eight
    shifted slices of the table, no gather."""
    a, b = first, last + 1
    x0, y0, z0 = (slice(int(v), int(v) + int(n)) for v, n in zip(a, size, strict=True))
    x1, y1, z1 = (slice(int(v), int(v) + int(n)) for v, n in zip(b, size, strict=True))
    return (sat[x1, y1, z1] - sat[x0, y1, z1] - sat[x1, y0, z1] - sat[x1, y1, z0]
            + sat[x0, y0, z1] + sat[x0, y1, z0] + sat[x1, y0, z0] - sat[x0, y0, z0])


def _block(counts: npt.NDArray[np.int32], params: GraphParams, observed: BoolArray | None,
           lo: npt.NDArray[np.int64], hi: npt.NDArray[np.int64]
           ) -> tuple[BoolArray, BoolArray, BoolArray]:
    """The rules over the cubes [lo, hi) (grid indices; the whole grid or a block of it):
    (viable, free) over the block grown by one cube on every side, and the edges of the
    block's cubes. Reads the counts only as far as the footprint reaches beyond that; the
    field's walls, floor and ceiling beyond the grid count as full (``corridor_threshold``
    points per cube), so every box is inside the local table and needs no clipping."""
    shape = np.asarray(counts.shape, dtype=np.int64)
    n, m = params.inflation_cubes
    pad = np.array([n, n, m], dtype=np.int64)
    g_lo, g_hi = lo - 1, hi + 1  # the grown block: free of each edge's far end
    e_lo, e_hi = g_lo - pad, g_hi + pad  # the counts its boxes read
    local = np.full(tuple(e_hi - e_lo), params.corridor_threshold, dtype=np.int64)
    c_lo, c_hi = np.maximum(e_lo, 0), np.minimum(e_hi, shape)
    local[_slices(c_lo - e_lo, c_hi - c_lo)] = counts[_slices(c_lo, c_hi - c_lo)]
    sat = np.zeros(tuple(np.asarray(local.shape) + 1), dtype=np.int64)
    sat[1:, 1:, 1:] = local.cumsum(0).cumsum(1).cumsum(2)

    grown = g_hi - g_lo
    viable = np.zeros(tuple(grown), dtype=bool)  # cubes outside the grid: never viable
    v_lo, v_hi = np.maximum(g_lo, 0), np.minimum(g_hi, shape)
    inner = counts[_slices(v_lo, v_hi - v_lo)] <= params.occupied_threshold
    for axis in range(3):  # boundary cubes are non-viable
        ix = np.arange(v_lo[axis], v_hi[axis])
        edge = (ix == 0) | (ix == shape[axis] - 1)
        inner &= ~edge.reshape([-1 if a == axis else 1 for a in range(3)])
    res = params.resolution
    top = min(shape[2] * res - params.ceiling_clearance, params.max_altitude)
    if top < shape[2] * res or params.min_altitude > 0.0:  # no waypoint outside the band
        z = (np.arange(v_lo[2], v_hi[2]) + 0.5) * res
        band = (z <= top + 1e-9) & (z >= params.min_altitude - 1e-9)
        inner &= band.reshape(1, 1, -1)
    if params.unknown_is_occupied:
        assert observed is not None
        inner &= observed[_slices(v_lo, v_hi - v_lo)]
    viable[_slices(v_lo - g_lo, v_hi - v_lo)] = inner
    # own box of each grown-block cube: local index = cube - e_lo = (cube - g_lo) + pad
    own = _box_sums_over(sat, np.zeros(3, dtype=np.int64), 2 * pad, grown)
    free = viable & (own < params.corridor_threshold)

    size = hi - lo
    edges = np.zeros((len(OFFSETS), *size), dtype=bool)
    here = free[_slices(np.ones(3, dtype=np.int64), size)]
    for d, off in enumerate(OFFSETS):  # 10 directions, each vectorised over the block
        there = free[_slices(1 + off, size)]  # cubes outside the grid are not free
        # corridor [min(c, c + off) - pad, max(c, c + off) + pad]; local c = (c - lo) + 1 + pad
        corridor = _box_sums_over(sat, 1 + np.minimum(off, 0), 1 + 2 * pad + np.maximum(off, 0),
                                  size)
        edges[d] = here & there & (corridor < params.corridor_threshold)
    return viable, free, edges


def _check_observed(params: GraphParams, observed: BoolArray | None, grid: Grid) -> None:
    if params.unknown_is_occupied:
        if observed is None:
            raise ValueError("unknown_is_occupied needs the observed cubes")
        if observed.shape != grid.shape:
            raise ValueError(f"observed cubes: shape {observed.shape}, grid {grid.shape}")


def build_graph(points: npt.ArrayLike, field_min: npt.ArrayLike, field_max: npt.ArrayLike,
                params: GraphParams, observed: BoolArray | None = None, *,
                empty_is_free: bool = False) -> VoxelGraph:
    """The graph of ``points`` (N, 3) [m, map frame] over the field box, by the rules of
    the module docstring. ``observed``: cubes seen by the sensor (grid shape), used when
    ``params.unknown_is_occupied``. ``empty_is_free``: no point in the field is a graph of
    free space (walls, floor and ceiling still bound it) rather than EmptyCloud
    (:func:`count_points`)."""
    grid = Grid.over(field_min, field_max, params.resolution)
    counts = count_points(points, grid, empty_is_free=empty_is_free)
    _check_observed(params, observed, grid)
    shape = np.asarray(grid.shape, dtype=np.int64)
    viable, free, edges = _block(counts, params, observed, np.zeros(3, dtype=np.int64), shape)
    inside = (slice(1, -1),) * 3
    return VoxelGraph(grid, params, counts, viable[inside], free[inside], edges)


def mattering_changes(old: npt.NDArray[np.int32], new: npt.NDArray[np.int32],
                      params: GraphParams) -> BoolArray:
    """The cubes whose new point count can change the graph. A count enters the rules only
    through ``count <= occupied_threshold`` (the cube's viability) and through box sums
    compared with ``corridor_threshold``; a box holding a cube with at least that many
    points fails the comparison whatever the rest holds. So a change matters unless the
    cube held at least ``corridor_threshold`` points before and after, on the same side of
    ``occupied_threshold`` (e.g. the depth camera adding points to a wall already mapped)."""
    t, o = params.corridor_threshold, params.occupied_threshold
    same = (old >= t) & (new >= t) & ((old <= o) == (new <= o))
    return (old != new) & ~same


def update_graph(graph: VoxelGraph, counts: npt.NDArray[np.int32],
                 observed: BoolArray | None = None) -> tuple[VoxelGraph, int]:
    """The graph of new per-cube point counts (:func:`count_points` on the same grid),
    equal to :func:`build_graph` on the new cloud, computed only over the block that the
    changes reach: the bounding box of the :func:`mattering_changes`, grown by the
    footprint's inflation plus one cube. Returns (graph, cubes recomputed); no mattering
    change: the same viability, free cubes and edges, with the new counts. ``observed``
    as for :func:`build_graph` (its changes are not tracked here: pass the same cubes)."""
    grid, params = graph.grid, graph.params
    if counts.shape != grid.shape:
        raise ValueError(f"counts of shape {counts.shape} for a grid of {grid.shape}")
    _check_observed(params, observed, grid)
    changed = np.argwhere(mattering_changes(graph.counts, counts, params))
    if len(changed) == 0:
        return VoxelGraph(grid, params, counts, graph.viable, graph.free, graph.edges), 0
    n, m = params.inflation_cubes
    reach = np.array([n, n, m], dtype=np.int64) + 1
    shape = np.asarray(grid.shape, dtype=np.int64)
    lo = np.maximum(changed.min(axis=0) - reach, 0)
    hi = np.minimum(changed.max(axis=0) + 1 + reach, shape)
    viable_b, free_b, edges_b = _block(counts, params, observed, lo, hi)
    block = _slices(lo, hi - lo)
    inside = (slice(1, -1),) * 3
    viable, free, edges = graph.viable.copy(), graph.free.copy(), graph.edges.copy()
    viable[block] = viable_b[inside]
    free[block] = free_b[inside]
    edges[(slice(None), *block)] = edges_b
    return VoxelGraph(grid, params, counts, viable, free, edges), int(np.prod(hi - lo))


# -- cache ---------------------------------------------------------------------------------
def cache_key(points: npt.ArrayLike, field_min: npt.ArrayLike, field_max: npt.ArrayLike,
              params: GraphParams, observed: BoolArray | None = None, *,
              empty_is_free: bool = False) -> str:
    """A digest of everything the graph depends on: the cloud's bytes (float64), the field,
    the parameters, the observed cubes, ``empty_is_free`` and the rules' version."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(np.asarray(points, dtype=np.float64)).tobytes())
    meta = {"min": np.asarray(field_min, dtype=np.float64).tolist(),
            "max": np.asarray(field_max, dtype=np.float64).tolist(),
            "params": asdict(params), "version": GRAPH_VERSION, "empty_is_free": empty_is_free}
    h.update(json.dumps(meta, sort_keys=True).encode())
    if observed is not None:
        h.update(np.packbits(observed).tobytes())
    return h.hexdigest()[:32]


def cached_graph(points: npt.ArrayLike, field_min: npt.ArrayLike, field_max: npt.ArrayLike,
                 params: GraphParams, cache_dir: Path,
                 observed: BoolArray | None = None, *,
                 empty_is_free: bool = False) -> tuple[VoxelGraph, bool]:
    """:func:`build_graph`, loaded from ``cache_dir`` when it was built before with the same
    inputs, else built and saved there. Returns (graph, came from the cache)."""
    key = cache_key(points, field_min, field_max, params, observed, empty_is_free=empty_is_free)
    path = Path(cache_dir) / f"voxel_graph_{key}.npz"
    if path.is_file():
        try:
            with np.load(path) as z:
                grid = Grid(tuple(float(v) for v in z["origin"]),  # type: ignore[arg-type]
                            float(z["resolution"]), tuple(int(v) for v in z["shape"]))  # type: ignore[arg-type]
                return VoxelGraph(grid, params, z["counts"], z["viable"], z["free"],
                                  z["edges"]), True
        except (OSError, KeyError, ValueError):
            pass  # a damaged cache file: rebuild and overwrite it
    graph = build_graph(points, field_min, field_max, params, observed,
                        empty_is_free=empty_is_free)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, origin=np.asarray(graph.grid.origin),
                        resolution=np.asarray(graph.grid.resolution),
                        shape=np.asarray(graph.grid.shape), counts=graph.counts,
                        viable=graph.viable, free=graph.free, edges=graph.edges)
    tmp.replace(path)
    return graph, False


__all__ = ["OFFSETS", "OPPOSITE", "GraphParams", "Grid", "VoxelGraph", "build_graph",
           "cache_key", "cached_graph", "count_points", "mattering_changes", "update_graph"]
