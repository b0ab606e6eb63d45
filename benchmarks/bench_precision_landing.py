"""Landing accuracy: the seed's precision landing (latest pose, filter on the error, no
phases) against ours (pose at capture time, phases with search, outlier rejection), over
the same seeded landings.

Landings run over random arenas (``sim/arena_generator.py``) and pads in a seeded order,
``--landings`` of them (default 30), each flown with both strategies from the same start
through the whole companion stack
(``quadmission/scenarios/precision_landing/scenario.py``); the error is
the true touchdown point against the pad centre. The down camera has its configured
exposure-to-publication latency (``config/sim_sensors.yaml``, 50 ms: recorded as
``camera_latency_s``). Writes RMSE, max, inside-pad count and the ratios ours/seed (RMSE,
worst case) to ``--out`` (default benchmarks/results/precision_landing.json),
rewritten after every landing so a long run can be read while it goes.
Slow: ~1 min of host time per landing and strategy on an idle 2-core machine, so
``--only A:B`` flies the landings A..B-1 alone (the same landings as in the full run) and
``--merge PART... --out OUT`` joins such parts into one result.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from _harness import bench_parser, progress, write_result

from quadmission.scenarios.precision_landing.scenario import (
    fly_episode,
    landing_json,
    start_position,
    summary,
)
from runtime import DeterministicExecutor
from sim.arena import Lighting
from sim.arena_generator import generate_arena
from sim.sensors import SimSensorsNode

STRATEGIES = ("seed", "capture")  # precision_land's strategy parameter: the seed's, ours


def camera_latency_s() -> float:
    """The down camera's exposure-to-publication latency [s] the landings fly with, as
    the sensors node reads it from ``config/sim_sensors.yaml``."""
    node = SimSensorsNode(context=DeterministicExecutor().context)
    return float(node.params.down_camera.latency_s)


def _ratio(ours: float | None, base: float | None) -> float | None:
    return round(ours / base, 3) if base and ours is not None else None


def result_of(episodes: dict[str, list[dict[str, Any]]], landings: int, seed: int,
              lighting: str) -> dict[str, Any]:
    """The benchmark's JSON of the episodes flown so far (both strategies, same order)."""
    s = {k: summary(v) for k, v in episodes.items()}
    ours, base = s["capture"], s["seed"]
    flown = min(len(v) for v in episodes.values())
    return {"benchmark": "precision_landing", "landings": landings, "flown": flown,
            "seed": seed, "lighting": lighting, "camera_latency_s": camera_latency_s(),
            "seed_algorithm": base, "ours": ours,
            "rmse_ratio_ours_over_seed": _ratio(ours["rmse_m"], base["rmse_m"]),
            "max_ratio_ours_over_seed": _ratio(ours["max_error_m"], base["max_error_m"]),
            "episodes": episodes}


def run(landings: int, seed: int, lighting: Lighting, only: range, out: Path) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    episodes: dict[str, list[dict[str, Any]]] = {k: [] for k in STRATEGIES}
    result = result_of(episodes, landings, seed, lighting.value)
    for i in range(landings):
        # every landing draws its arena and pad, flown or not: a part flies the same ones
        arena_seed = int(rng.integers(1, 10_000))
        pad_index = int(rng.integers(1_000_000))
        if i not in only:
            continue
        arena = replace(generate_arena(arena_seed), lighting=lighting)
        pad = arena.pads[pad_index % len(arena.pads)]
        start = start_position(arena, pad, np.random.default_rng([seed, i]))
        for strategy, done in episodes.items():
            episode = fly_episode(arena, pad, start, seed=seed * 1000 + i,
                                  landing_overrides={"strategy": strategy})
            d = landing_json(episode) | {"landing": i, "arena_seed": arena_seed}
            done.append(d)
            err = d["touchdown_error_m"]
            progress(f"{i + 1:2d}/{landings} arena {arena_seed} pad {pad.id} {strategy:7s}: "
                     + ("failed: " + d["message"] if err is None
                        else f"{100 * float(err):.1f} cm"))
        result = result_of(episodes, landings, seed, lighting.value)
        write_result(out, result)
    return result


def merge(parts: list[dict[str, Any]]) -> dict[str, Any]:
    """One result of parts of the same run (same landings, seed, lighting)."""
    keys = {(p["landings"], p["seed"], p["lighting"]) for p in parts}
    if len(keys) != 1:
        raise ValueError(f"merge: the parts come from different runs: {sorted(keys)}")
    ((landings, seed, lighting),) = keys
    episodes = {k: sorted((d for p in parts for d in p["episodes"][k]),
                          key=lambda d: d["landing"]) for k in STRATEGIES}
    return result_of(episodes, landings, seed, lighting)


def main() -> None:
    parser = bench_parser(__doc__, "precision_landing")
    parser.add_argument("--landings", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--lighting", choices=[x.value for x in Lighting], default="light")
    parser.add_argument("--only", default=None, metavar="A:B",
                        help="fly only the landings A..B-1 of the run")
    parser.add_argument("--merge", nargs="+", type=Path, default=None, metavar="PART",
                        help="join parts written with --only into --out")
    args = parser.parse_args()
    if args.merge:
        write_result(args.out, merge([json.loads(p.read_text()) for p in args.merge]))
        return
    only = range(args.landings)
    if args.only is not None:
        a, _, b = args.only.partition(":")
        only = range(int(a or 0), int(b or args.landings))
    run(args.landings, args.seed, Lighting(args.lighting), only, args.out)


if __name__ == "__main__":
    main()
