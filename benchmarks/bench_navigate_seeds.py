"""The navigate scenario in the default arena and in random arenas (issue 9's done-when).

    python benchmarks/bench_navigate_seeds.py --out benchmarks/results/navigate_seeds.json
    python benchmarks/bench_navigate_seeds.py --seeds 10 --no-default --out /tmp/n.json

Runs ``quadmission sim --scenario navigate`` in the default arena (seed 0) and with
``--random-arena --seed N`` for each seed (default 1-10), each into its own folder
(``--runs``; ``--resume`` reads the runs already there), ``--jobs`` at a time (each run in its
own process); records each outcome:
pads reached, crash, the smallest clearance to an obstacle over the legs, tracking RMSE,
and how the path finder kept its graph (full builds, block updates, map changes that did
not matter). The target: every run reaches all 9 pads with no crash. Quality figures, not
timings (the wall time per run is in each report's host block).
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from _harness import bench_parser, seed_list, write_result

os.environ.setdefault("MUJOCO_GL", "egl")


def run_one(out: Path, seed: int, random_arena: bool, resume: bool = False) -> dict[str, Any]:
    from quadmission.scenarios import ScenarioOptions
    from quadmission.scenarios.navigate import navigate

    if resume and (out / "report.json").is_file():
        report = json.loads((out / "report.json").read_text())
    else:
        report = navigate(ScenarioOptions(out=out, seed=seed, random_arena=random_arena))
    clearances = [leg["min_clearance_m"] for leg in report["legs"]
                  if leg["min_clearance_m"] is not None]
    return {"seed": seed, "random_arena": random_arena, "arena": report["arena"],
            "ok": report["ok"], "crashed": report["crashed"], "verdict": report["verdict"],
            "pads_reached": report["pads_reached"], "pads_total": report["pads_total"],
            "min_clearance_m": min(clearances, default=None), "rmse_m": report["rmse_m"],
            "sim_time_s": report["sim_time_s"], "graph_builds": report["graph_builds"],
            "graph_updates": report["graph_updates"],
            "graph_unchanged": report["graph_unchanged"],
            "plan_requests": report["plan_requests"],
            "wall_time_s": report["host"]["wall_time_s"]}


def main() -> None:
    parser = bench_parser(__doc__, "navigate_seeds")
    parser.add_argument("--seeds", default="1-10", help="e.g. 1-10 or 3,7")
    parser.add_argument("--no-default", action="store_true", help="skip the default arena")
    parser.add_argument("--jobs", type=int, default=2, help="runs at a time")
    parser.add_argument("--runs", type=Path, default=Path("runs/navigate_seeds"),
                        help="folder for each run's report.json and path.png")
    parser.add_argument("--resume", action="store_true",
                        help="read a run whose folder has a report.json instead of flying it")
    args = parser.parse_args()
    todo = [] if args.no_default else [(args.runs / "default", 0, False)]
    todo += [(args.runs / f"seed_{s}", s, True) for s in seed_list(args.seeds)]
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn")) as pool:
        futures = [pool.submit(run_one, *job, args.resume) for job in todo]
        runs = []
        for (_, seed, random_arena), future in zip(todo, futures, strict=True):
            runs.append(future.result())
            name = f"seed {seed:2d}" if random_arena else "default arena"
            print(f"{name}: {runs[-1]['verdict']}", flush=True)
    runs.sort(key=lambda r: (r["random_arena"], r["seed"]))
    result = {
        "runs": runs,
        "all_pads_no_crash": sum(r["ok"] for r in runs),
        "crashed": sum(r["crashed"] for r in runs),
        "total": len(runs),
        "min_clearance_m": min((r["min_clearance_m"] for r in runs
                                if r["min_clearance_m"] is not None), default=None),
    }
    write_result(args.out, result, allow_nan=False)
    print(json.dumps({k: v for k, v in result.items() if k != "runs"}))


if __name__ == "__main__":
    main()
