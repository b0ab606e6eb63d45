"""A* on the voxel graph against networkx and libtcod, on the default arena's mapped cloud.

The cloud: the default arena seen by the simulated forward depth camera (its noise, its
range) from a grid of hover points at two heights and eight headings, fused with the true
poses into a 5 cm voxel map (``--map FILE`` uses a map file instead, e.g. the ``map.pcd`` of
``quadmission sim --scenario map-arena``). For each resolution (0.2 m and 0.1 m):

- graph build time for the cloud (median of 3) and for 1 M uniform random points;
- A* corner to corner and on seeded random pairs of free cubes: ours (numba; the seed's
  Euclidean heuristic, and the octile option, same optimal cost), networkx's
  ``astar_path`` on the same graph (same edges, same Euclidean costs and heuristic: the
  same cost to 1e-9 is checked) and libtcod's C A* (``tcod.path``, integer costs: edge
  cost = round(1000 x metres), its own admissible heuristic; the same queries). Times are
  per query, host seconds; a query's four runs are back to back, so the host's load weighs
  on each alike. All the queries are run ``--rounds`` times; a round's ratio is the median
  of its per-query ratios, and a figure is reported as the median of the rounds' with
  their min / median / max (``*_rounds``), the spread the host's load gives;
- the line-of-sight shortcut: path length and waypoint reduction.

Ratios (``speedup_vs_networkx_median`` = networkx / ours; ``time_ratio_vs_tcod_median`` =
ours / tcod) are what to compare, not absolute times; the tcod ratio is the steady one. The
networkx ratio moves with the host's speed, about 3x between a slow host and an idle one
(networkx is pure Python: it slows more than ours when the host is slow), so the run also
times a fixed pure-Python loop before and after the queries (``host.reference_loop_s``,
``_harness.reference_loop_s``): two runs' networkx ratios are comparable when those agree.

    python benchmarks/bench_astar.py --out benchmarks/results/astar.json
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np
from _harness import REQUIRED, bench_parser, host, progress, reference_loop_s, write_result

from navigation.astar import Heuristic, Workspace, astar, path_length, shortcut
from navigation.mapping import VoxelMap, camera_to_map, load_map
from navigation.voxel_graph import OFFSETS, GraphParams, VoxelGraph, build_graph
from sim.arena import ArenaSpec, default_arena
from sim.render import DepthPointCloud, SceneRenderer
from sim.scene import place_quadrotor
from sim.world import Scene

SEED = 0
MAP_VOXEL = 0.05  # m
CAMERA_OFFSET = (0.12, 0.0, 0.0)  # m, the depth camera in the body frame (config/mapping.yaml)


def params(resolution: float) -> GraphParams:
    """The path finder's settings (config/path_finder.yaml) at ``resolution``."""
    return GraphParams(resolution=resolution, occupied_threshold=2, corridor_threshold=1,
                       footprint_radius=0.35, safety_margin=0.05, vertical_clearance=0.2)


def survey_cloud(arena: ArenaSpec, spacing: float = 2.5) -> np.ndarray:
    """The arena as the depth camera sees it from a grid of hover points (true poses)."""
    scene = Scene.build(arena)
    vmap = VoxelMap(MAP_VOXEL)
    fx, fy, _ = arena.field.size
    with SceneRenderer(scene.model) as renderer:
        camera = DepthPointCloud(renderer, scene.quad.depth_camera, noise_std=0.01, seed=SEED)
        for z in (1.0, 2.0):
            for x in np.arange(1.0, fx, spacing):
                for y in np.arange(1.0, fy, spacing):
                    for yaw in np.arange(8) * math.pi / 4:
                        place_quadrotor(scene.model, scene.data, scene.index, (x, y, z), yaw)
                        q = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
                        pts = camera_to_map(camera.points(scene.data), (x, y, z), q,
                                            CAMERA_OFFSET, max_range=6.0)
                        vmap.add(pts[pts[:, 2] >= 0.05])
    return vmap.points()


def timed(fn: Any, repeat: int = 1) -> tuple[float, Any]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def networkx_graph(g: VoxelGraph) -> Any:
    import networkx as nx

    G = nx.Graph()
    costs = g.step_costs
    for d in range(0, len(OFFSETS), 2):  # one direction of each pair: the graph is symmetric
        src = np.argwhere(g.edges[d])
        a = g.grid.flat(src)
        b = g.grid.flat(src + OFFSETS[d])
        G.add_weighted_edges_from(zip(a.tolist(), b.tolist(), [float(costs[d])] * len(a),
                                      strict=True))
    return G


def tcod_graph(g: VoxelGraph) -> Any:
    """libtcod's graph of the same edges, axes (z, x, y) so that its heuristic's
    cardinal/diagonal are the horizontal plane and ``z`` the vertical."""
    import tcod.path

    nx_, ny_, nz_ = g.grid.shape
    graph = tcod.path.CustomGraph((nz_, nx_, ny_))
    cost = np.ones((nz_, nx_, ny_), dtype=np.int32)
    for d, off in enumerate(OFFSETS):
        step = round(1000 * float(g.step_costs[d]))
        graph.add_edge((int(off[2]), int(off[0]), int(off[1])), step, cost=cost,
                       condition=np.ascontiguousarray(g.edges[d].transpose(2, 0, 1)))
    unit = round(1000 * g.grid.resolution)
    graph.set_heuristic(cardinal=unit, diagonal=round(1000 * g.grid.resolution * math.sqrt(2)),
                        z=unit)
    return graph


def tcod_query(graph: Any, g: VoxelGraph, s: int, t: int) -> np.ndarray:
    import tcod.path

    sc, tc = g.grid.unflat(s), g.grid.unflat(t)
    pf = tcod.path.Pathfinder(graph)
    pf.add_root((int(sc[2]), int(sc[0]), int(sc[1])))
    path = pf.path_to((int(tc[2]), int(tc[0]), int(tc[1])))
    return path[:, [1, 2, 0]]  # back to (x, y, z)


def corner_pair(g: VoxelGraph, altitude: float = 1.5) -> tuple[int, int]:
    """The free cubes nearest the south-west and north-east corners at ``altitude``."""
    free = np.argwhere(g.free)
    centres = g.grid.center(free)
    lo = np.asarray(g.grid.origin)
    hi = lo + np.asarray(g.grid.shape) * g.grid.resolution
    s = free[np.argmin(np.linalg.norm(centres - [lo[0], lo[1], altitude], axis=1))]
    t = free[np.argmin(np.linalg.norm(centres - [hi[0], hi[1], altitude], axis=1))]
    return int(g.grid.flat(s[None])[0]), int(g.grid.flat(t[None])[0])


def random_pairs(g: VoxelGraph, n: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    """Pairs of free cubes between 0.5 and 2.5 m high, start and goal in the component of
    the first one drawn (our search checks it: a pair with no path is redrawn)."""
    centres_z = g.grid.center(g.grid.unflat(np.flatnonzero(g.free)))[:, 2]
    pool = np.flatnonzero(g.free)[(centres_z > 0.5) & (centres_z < 2.5)]
    pairs: list[tuple[int, int]] = []
    while len(pairs) < n:
        s, t = (int(v) for v in rng.choice(pool, 2, replace=False))
        if astar(g, s, t).cells.size:
            pairs.append((s, t))
    return pairs


def query_times(g: VoxelGraph, ws: Workspace, s: int, t: int, tcod_graph_: Any,
                networkx: tuple[Any, Any] | None) -> dict[str, Any]:
    """One query's times, back to back so that the host's load weighs on all alike: ours
    (median of 3), octile (median of 3), tcod (median of 3) and networkx (once) when given
    (graph, heuristic). Also the results, for the checks."""
    ours_s, res_ = timed(lambda: astar(g, s, t, workspace=ws), repeat=3)
    oct_s, res_oct = timed(lambda: astar(g, s, t, heuristic=Heuristic.OCTILE, workspace=ws),
                           repeat=3)
    tcod_s, tpath = timed(lambda: tcod_query(tcod_graph_, g, s, t), repeat=3)
    row = {"ours_s": ours_s, "octile_s": oct_s, "tcod_s": tcod_s, "result": res_,
           "octile_result": res_oct, "tcod_path": tpath}
    if networkx is not None:
        import networkx as nx

        G, h = networkx
        nx_s, npath = timed(lambda: nx.astar_path(G, s, t, heuristic=h, weight="weight"))
        row |= {"networkx_s": nx_s, "networkx_path": npath}
    return row


def spread(values: list[float]) -> dict[str, float]:
    """min / median / max of per-round figures."""
    return {"min": min(values), "median": statistics.median(values), "max": max(values)}


def round_figures(rows: list[dict[str, Any]]) -> dict[str, float]:
    """One round's medians of per-query times and ratios."""
    with_nx = [r for r in rows if "networkx_s" in r]
    return {
        "ours_s_median": statistics.median(r["ours_s"] for r in rows),
        "networkx_s_median": statistics.median(r["networkx_s"] for r in with_nx),
        "tcod_s_median": statistics.median(r["tcod_s"] for r in rows),
        "speedup_vs_networkx_median": statistics.median(r["networkx_s"] / r["ours_s"]
                                                        for r in with_nx),
        "time_ratio_vs_tcod_median": statistics.median(r["ours_s"] / r["tcod_s"] for r in rows),
        "octile_s_median": statistics.median(r["octile_s"] for r in rows),
        "octile_speedup_vs_networkx_median": statistics.median(r["networkx_s"] / r["octile_s"]
                                                               for r in with_nx),
        "octile_time_ratio_vs_tcod_median": statistics.median(r["octile_s"] / r["tcod_s"]
                                                              for r in rows),
        "corner_ours_s": rows[0]["ours_s"],
        "corner_octile_s": rows[0]["octile_s"],
        "corner_tcod_s": rows[0]["tcod_s"],
        "corner_networkx_s": rows[0]["networkx_s"],
    }


def bench_resolution(points: np.ndarray, field_max: tuple[float, float, float], res: float,
                     n_pairs: int, n_networkx: int, rounds: int,
                     rng: np.random.Generator) -> dict[str, Any]:
    p = params(res)
    build_s, g = timed(lambda: build_graph(points, (0, 0, 0), field_max, p), repeat=3)
    big = rng.uniform((0, 0, 0), field_max, (1_000_000, 3))
    build_1m_s, _ = timed(lambda: build_graph(big, (0, 0, 0), field_max, p), repeat=3)
    ws = Workspace(g.grid.size)
    for h in Heuristic:
        astar(g, *corner_pair(g), heuristic=h, workspace=ws)  # compile / warm up
    pairs = [corner_pair(g), *random_pairs(g, n_pairs, rng)]

    import networkx as nx

    G_s, G = timed(lambda: networkx_graph(g))
    centres = {}

    def h(a: int, b: int) -> float:
        for c in (a, b):
            if c not in centres:
                centres[c] = g.grid.center(g.grid.unflat(c))[0]
        return float(np.linalg.norm(centres[a] - centres[b]))

    T_s, T = timed(lambda: tcod_graph(g))
    per_round: list[dict[str, float]] = []
    rows: list[dict[str, Any]] = []
    for r in range(rounds):
        progress(f"  round {r + 1}/{rounds}")
        this = [query_times(g, ws, s, t, T, (G, h) if k < n_networkx else None)
                for k, (s, t) in enumerate(pairs)]
        per_round.append(round_figures(this))
        if r == 0:
            rows = this  # the results are the same every round: checked on the first
    checks = []
    for row in rows:
        res_, res_oct = row["result"], row["octile_result"]
        check = {"cost_m": res_.cost, "expansions": res_.expansions,
                 "tcod_cost_m": path_length(g.grid.center(row["tcod_path"])),
                 "octile_cost_m": res_oct.cost, "octile_expansions": res_oct.expansions}
        if "networkx_path" in row:
            nx_cost = float(nx.path_weight(G, row["networkx_path"], weight="weight"))
            check["same_cost"] = abs(nx_cost - res_.cost) <= 1e-9
        short = shortcut(g, g.grid.center(g.grid.unflat(res_.cells)))
        check |= {"waypoints": len(res_.cells), "shortcut_waypoints": len(short),
                  "shortcut_length_m": path_length(short)}
        checks.append(check)
    with_nx = [c for c in checks if "same_cost" in c]

    def med(key: str) -> float:
        return statistics.median(f[key] for f in per_round)

    return {
        "resolution_m": res,
        "grid_shape": list(g.grid.shape),
        "free_cubes": int(g.free.sum()),
        "edges": g.edge_count,
        "build_s_median": build_s,
        "build_1m_points_s_median": build_1m_s,
        "networkx_graph_build_s": G_s,
        "tcod_graph_build_s": T_s,
        "queries": len(checks),
        "networkx_queries": len(with_nx),
        "rounds": rounds,
        "corner_to_corner": {
            "ours_s": med("corner_ours_s"), "octile_s": med("corner_octile_s"),
            "networkx_s": med("corner_networkx_s"), "tcod_s": med("corner_tcod_s"),
            "speedup_vs_networkx": spread([f["corner_networkx_s"] / f["corner_ours_s"]
                                           for f in per_round]),
            "cost_m": checks[0]["cost_m"], "expansions": checks[0]["expansions"],
            "octile_expansions": checks[0]["octile_expansions"]},
        "ours_s_median": med("ours_s_median"),
        "networkx_s_median": med("networkx_s_median"),
        "tcod_s_median": med("tcod_s_median"),
        "speedup_vs_networkx_median": med("speedup_vs_networkx_median"),
        "speedup_vs_networkx_rounds": spread([f["speedup_vs_networkx_median"]
                                              for f in per_round]),
        "time_ratio_vs_tcod_median": med("time_ratio_vs_tcod_median"),
        "time_ratio_vs_tcod_rounds": spread([f["time_ratio_vs_tcod_median"]
                                             for f in per_round]),
        "same_cost_as_networkx": all(c["same_cost"] for c in with_nx),
        "octile": {
            "ours_s_median": med("octile_s_median"),
            "speedup_vs_networkx_median": med("octile_speedup_vs_networkx_median"),
            "speedup_vs_networkx_rounds": spread([f["octile_speedup_vs_networkx_median"]
                                                  for f in per_round]),
            "time_ratio_vs_tcod_median": med("octile_time_ratio_vs_tcod_median"),
            "time_ratio_vs_tcod_rounds": spread([f["octile_time_ratio_vs_tcod_median"]
                                                 for f in per_round]),
            "same_cost_as_euclidean": all(abs(c["octile_cost_m"] - c["cost_m"]) <= 1e-9
                                          for c in checks),
            "expansions_ratio_median": statistics.median(
                c["octile_expansions"] / c["expansions"] for c in checks),
        },
        "max_cost_diff_vs_tcod_m": max(abs(c["tcod_cost_m"] - c["cost_m"]) for c in checks),
        "shortcut": {
            "length_ratio_median": statistics.median(c["shortcut_length_m"] / c["cost_m"]
                                                     for c in checks if c["cost_m"] > 0),
            "waypoint_ratio_median": statistics.median(c["shortcut_waypoints"] / c["waypoints"]
                                                       for c in checks),
        },
        "per_round": per_round,
    }


def main() -> None:
    ap = bench_parser(__doc__, REQUIRED)
    ap.add_argument("--map", type=Path, default=None, help="PCD/PLY map instead of the survey")
    ap.add_argument("--pairs", type=int, default=200, help="random pairs per resolution")
    ap.add_argument("--resolutions", default="0.2,0.1", help="cube sides [m]")
    ap.add_argument("--networkx-pairs", default="201,21",
                    help="queries also run on networkx, per resolution (it is slow at 0.1 m)")
    ap.add_argument("--rounds", type=int, default=3,
                    help="rounds of all the queries; ratios are reported per round and as "
                         "min / median / max over the rounds")
    ap.add_argument("--cloud-cache", type=Path, default=None,
                    help=".npy file: the survey's cloud is read from it when it exists, else "
                         "surveyed and written there (the survey takes minutes)")
    args = ap.parse_args()
    if args.rounds < 1:
        ap.error(f"--rounds: {args.rounds} must be >= 1")
    arena = default_arena()
    fx, fy, fz = arena.field.size
    # the host's load and speed before and after: other work skews times
    load_start, loop_start = os.getloadavg()[0], reference_loop_s()
    t0 = time.perf_counter()
    progress("cloud ...")
    cloud = str(args.map) if args.map else "default arena depth survey (true poses)"
    if args.map:
        points = load_map(args.map)
    elif args.cloud_cache is not None and args.cloud_cache.is_file():
        points = np.load(args.cloud_cache)
        cloud += f", read from {args.cloud_cache}"
    else:
        points = survey_cloud(arena)
        if args.cloud_cache is not None:
            args.cloud_cache.parent.mkdir(parents=True, exist_ok=True)
            np.save(args.cloud_cache, points)
    cloud_s = time.perf_counter() - t0
    n_nx = [int(v) for v in args.networkx_pairs.split(",")]
    rng = np.random.default_rng(SEED)
    resolutions = [float(v) for v in args.resolutions.split(",")]
    results = []
    for i, res in enumerate(resolutions):
        progress(f"resolution {res} m: {len(points)} cloud points")
        results.append(bench_resolution(points, (fx, fy, fz), res, args.pairs, n_nx[i],
                                        args.rounds, rng))
    out = {
        "benchmark": "astar",
        "cloud": cloud,
        "cloud_points": len(points),
        "cloud_s": cloud_s,
        "resolutions": results,
        "speedup_vs_networkx_median": results[0]["speedup_vs_networkx_median"],
        "speedup_vs_networkx_rounds": results[0]["speedup_vs_networkx_rounds"],
        "time_ratio_vs_tcod_median": results[0]["time_ratio_vs_tcod_median"],
        "build_1m_points_s_median": results[0]["build_1m_points_s_median"],
        "octile_speedup_vs_networkx_median": results[0]["octile"]["speedup_vs_networkx_median"],
        "octile_time_ratio_vs_tcod_median": results[0]["octile"]["time_ratio_vs_tcod_median"],
        "host": host(load_average_1m=[load_start, os.getloadavg()[0]],
                     reference_loop_s=[round(loop_start, 4), round(reference_loop_s(), 4)]),
    }
    write_result(args.out, out)
    print(json.dumps({k: out[k] for k in ("speedup_vs_networkx_median",
                                          "speedup_vs_networkx_rounds",
                                          "time_ratio_vs_tcod_median",
                                          "octile_speedup_vs_networkx_median",
                                          "octile_time_ratio_vs_tcod_median",
                                          "build_1m_points_s_median")}))


if __name__ == "__main__":
    main()
