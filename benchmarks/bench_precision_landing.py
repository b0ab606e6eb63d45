"""Landing accuracy: the seed's precision landing (latest pose, filter on the error, no
phases) against ours (pose at capture time, phases with search, outlier rejection), over
the same seeded landings.

Landings run over random arenas (``sim/arena_generator.py``) and pads in a seeded order,
``--landings`` of them (default 30), each flown with both strategies from the same start
through the whole companion stack (``quadmission/precision_landing.py``); the error is
the true touchdown point against the pad centre. Writes RMSE, max, inside-pad count and
the ratio ours/seed to ``--out`` (default benchmarks/results/precision_landing.json).
Slow: ~1 min of host time per landing on an idle 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from quadmission.precision_landing import fly_episode, landing_json, start_position, summary
from sim.arena import Lighting
from sim.arena_generator import generate_arena


def run(landings: int, seed: int, lighting: Lighting) -> dict[str, object]:
    rng = np.random.default_rng(seed)
    results: dict[str, list[dict[str, object]]] = {"seed": [], "capture": []}
    for i in range(landings):
        arena_seed = int(rng.integers(1, 10_000))
        arena = generate_arena(arena_seed)
        arena = replace(arena, lighting=lighting)
        pad = arena.pads[int(rng.integers(len(arena.pads)))]
        start = start_position(arena, pad, np.random.default_rng([seed, i]))
        for strategy, out in results.items():
            episode = fly_episode(arena, pad, start, seed=seed * 1000 + i,
                                  landing_overrides={"strategy": strategy})
            d = landing_json(episode) | {"arena_seed": arena_seed}
            out.append(d)
            err = d["touchdown_error_m"]
            print(f"{i + 1:2d}/{landings} arena {arena_seed} pad {pad.id} {strategy:7s}: "
                  + ("failed" if err is None else f"{100 * float(err):.1f} cm"),
                  file=sys.stderr)
    s = {k: summary(v) for k, v in results.items()}
    ratio = (s["capture"]["rmse_m"] / s["seed"]["rmse_m"]
             if s["seed"]["rmse_m"] and s["capture"]["rmse_m"] is not None else math.nan)
    return {"benchmark": "precision_landing", "landings": landings, "seed": seed,
            "lighting": lighting.value, "seed_algorithm": s["seed"], "ours": s["capture"],
            "rmse_ratio_ours_over_seed": None if math.isnan(ratio) else round(ratio, 3),
            "episodes": results}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path,
                        default=Path(__file__).parent / "results" / "precision_landing.json")
    parser.add_argument("--landings", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--lighting", choices=[x.value for x in Lighting], default="light")
    args = parser.parse_args()
    result = run(args.landings, args.seed, Lighting(args.lighting))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
