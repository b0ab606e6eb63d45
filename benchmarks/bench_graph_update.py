"""The path finder's graph kept up to date as the live map grows: update vs full build.

    python benchmarks/bench_graph_update.py --out benchmarks/results/graph_update.json

The live map of a flight, replayed: the default arena seen by the simulated forward depth
camera from a grid of hover points at the cruise altitude, eight headings each, one depth
cloud per heading fused into a 0.1 m voxel map (``config/mapping.yaml``), in that order.
After each cloud the path finder needs the graph of the new map (0.2 m, the path finder's
settings): a full :func:`~navigation.voxel_graph.build_graph`, or
:func:`~navigation.voxel_graph.update_graph` of the previous graph (the block the
changes reach; nothing when they fall in cubes already full). Both give the same graph
(checked on every step). Recorded: per step, both host times; the median ratio (full /
update) and the share of steps with no change that matters. Ratios are what to compare
across machines.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

from _harness import REQUIRED, bench_parser, host, load_1min, write_result

from navigation.mapping import VoxelMap, camera_to_map
from navigation.voxel_graph import GraphParams, build_graph, count_points, update_graph
from sim.arena import default_arena
from sim.render import DepthPointCloud, SceneRenderer
from sim.scene import place_quadrotor
from sim.world import Scene

SEED = 0
VOXEL = 0.1  # m, config/mapping.yaml voxel_size
ALTITUDE = 1.5  # m, the navigator's cruise altitude
CAMERA_OFFSET = (0.12, 0.0, 0.0)  # m, config/mapping.yaml depth_camera_position
PARAMS = GraphParams(resolution=0.2, occupied_threshold=2, corridor_threshold=1,
                     footprint_radius=0.35, safety_margin=0.05, vertical_clearance=0.2)


def main() -> None:
    ap = bench_parser(__doc__, REQUIRED)
    ap.add_argument("--spacing", type=float, default=2.5, help="hover grid spacing [m]")
    args = ap.parse_args()
    arena = default_arena()
    fx, fy, fz = arena.field.size
    scene = Scene.build(arena)
    vmap = VoxelMap(VOXEL)
    graph = None
    steps = []
    with SceneRenderer(scene.model) as renderer:
        camera = DepthPointCloud(renderer, scene.quad.depth_camera, noise_std=0.01, seed=SEED)
        for x in np.arange(1.0, fx, args.spacing):
            for y in np.arange(1.0, fy, args.spacing):
                for yaw in np.arange(8) * math.pi / 4:
                    place_quadrotor(scene.model, scene.data, scene.index, (x, y, ALTITUDE), yaw)
                    q = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
                    pts = camera_to_map(camera.points(scene.data), (x, y, ALTITUDE), q,
                                        CAMERA_OFFSET, max_range=6.0)
                    if vmap.add(pts[pts[:, 2] >= 0.05]) == 0 and graph is not None:
                        continue  # no new voxel: the map is not published anew
                    points = vmap.points()
                    t0 = time.perf_counter()
                    full = build_graph(points, (0, 0, 0), (fx, fy, fz), PARAMS)
                    full_s = time.perf_counter() - t0
                    if graph is None:
                        graph = full
                        continue
                    t0 = time.perf_counter()
                    graph, cubes = update_graph(graph, count_points(points, graph.grid))
                    update_s = time.perf_counter() - t0
                    assert (np.array_equal(graph.free, full.free)
                            and np.array_equal(graph.edges, full.edges)), "not the same graph"
                    steps.append({"points": len(points), "full_s": full_s,
                                  "update_s": update_s, "cubes_updated": cubes})
    assert graph is not None
    out = {
        "benchmark": "graph_update",
        "arena": arena.name, "resolution_m": PARAMS.resolution, "grid_cubes": graph.grid.size,
        "steps": len(steps),
        "unchanged_share": sum(s["cubes_updated"] == 0 for s in steps) / len(steps),
        "cubes_updated_share_median": statistics.median(s["cubes_updated"] / graph.grid.size
                                                        for s in steps),
        "full_s_median": statistics.median(s["full_s"] for s in steps),
        "update_s_median": statistics.median(s["update_s"] for s in steps),
        "speedup_median": statistics.median(s["full_s"] / s["update_s"] for s in steps),
        "same_graph_every_step": True,
        "host": host(load_1min=load_1min()),
        "per_step": steps,
    }
    write_result(args.out, out)
    print(json.dumps({k: v for k, v in out.items() if k != "per_step"}))


if __name__ == "__main__":
    main()
