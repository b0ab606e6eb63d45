"""The square through the real companion stack, in the default arena and in random arenas.

    python benchmarks/bench_square_seeds.py --out benchmarks/results/square_seeds.json
    python benchmarks/bench_square_seeds.py --seeds 1-5 --out /tmp/s.json

Runs ``quadmission sim --random-arena --seed N`` for each seed (default 1-20), and the
default arena, each into its own folder next to the JSON result; records each outcome
(landed with its RMSE, crash, failure, or refused with the reason). The issue's target:
every seed lands or is refused with a reason; xy RMSE < 0.1 m, the true path against the
planned outline (what the RMSE is measured against is in the result, from the reports).
Quality figures, not timings (the wall time per run is in each report's host block).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

from _harness import bench_parser, seed_list, write_result

from quadmission.errors import ScenarioRefused
from quadmission.scenarios import ScenarioOptions
from quadmission.scenarios.square.flight import square

TARGET_XY_RMSE = 0.1  # m


def run_one(out: Path, seed: int, random_arena: bool) -> dict[str, Any]:
    options = ScenarioOptions(out=out, seed=seed, random_arena=random_arena)
    try:
        report = square(options)
    except ScenarioRefused:
        report = json.loads((out / "report.json").read_text())
    rmse = (report.get("tracking") or {}).get("rmse_m") or {}
    return {"seed": seed, "random_arena": random_arena, "arena": report["arena"],
            "outcome": report["outcome"], "verdict": report["verdict"],
            "xy_rmse_m": rmse.get("xy"),
            "rmse_reference": (report.get("tracking") or {}).get("reference"),
            "side_m": (report.get("square") or {}).get("side_m"),
            "wall_time_s": (report.get("host") or {}).get("wall_time_s")}


def main() -> None:
    parser = bench_parser(__doc__, "square_seeds")
    parser.add_argument("--seeds", default="1-20", help="e.g. 1-20 or 3,7")
    parser.add_argument("--runs", type=Path, default=Path("runs/square_seeds"),
                        help="folder for each run's report.json and path.png")
    args = parser.parse_args()
    runs = [run_one(args.runs / "default", 0, random_arena=False)]
    print(f"default arena: {runs[0]['verdict']}", flush=True)
    for seed in seed_list(args.seeds):
        runs.append(run_one(args.runs / f"seed_{seed}", seed, random_arena=True))
        print(f"seed {seed:2d}: {runs[-1]['verdict']}", flush=True)
    landed = [r for r in runs if r["outcome"] == "landed"]
    result = {
        "target_xy_rmse_m": TARGET_XY_RMSE,
        "runs": runs,
        "landed": len(landed),
        "refused": sum(r["outcome"] == "refused" for r in runs),
        "crashed_or_failed": sum(r["outcome"] in ("crash", "failed") for r in runs),
        "worst_xy_rmse_m": max((r["xy_rmse_m"] for r in landed), default=None),
        "all_within_target": all(r["xy_rmse_m"] < TARGET_XY_RMSE for r in landed),
    }
    write_result(args.out, result, allow_nan=False)
    print(json.dumps({k: v for k, v in result.items() if k != "runs"}))


if __name__ == "__main__":
    main()
