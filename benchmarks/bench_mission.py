"""The contest mission in seeded random arenas: success rate, score ratio, wall time.

    python benchmarks/bench_mission.py --out benchmarks/results/mission.json
    python benchmarks/bench_mission.py --seeds 1-5 --jobs 2 --out /tmp/m.json

Runs ``quadmission sim --scenario mission --random-arena --seed N`` for each seed
(default 1-20), each into its own folder next to the JSON result (report.json, pictures),
in ``--jobs`` processes. A run succeeds when the mission completed, every pad of its
sequence was landed inside, and nothing crashed (the report's ``ok``). Reported: the
success rate (issue target: at least 18/20, goal 20/20), the mean score ratio (true score
over the operator's planned points; also over the robot's whole table), and the p50 / max
wall time per run, with the real-time factor. Quality figures first; wall times depend on
the host and its load. The JSON is rewritten after every run, so a stopped benchmark
keeps what it measured (``runs_done`` of ``runs_planned``). Seeds can be flown in parts
(``--seeds 1-10`` into one JSON, ``--seeds 11-20`` into another, even on two machines):
``--merge OUT PART...`` joins them, a seed's last run winning.
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from _harness import bench_parser, seed_list, write_result

os.environ.setdefault("MUJOCO_GL", "egl")

TARGET_SUCCESSES = 18  # of 20 (the issue's); the goal is all of them


def run_one(out: Path, seed: int) -> dict[str, Any]:
    from quadmission.scenarios import ScenarioOptions
    from quadmission.scenarios.mission.scenario import fly_mission

    try:
        report = fly_mission(ScenarioOptions(out=out, seed=seed, random_arena=True))
    except Exception as exc:  # a broken run is a failed run, with its reason
        return {"seed": seed, "ok": False, "verdict": f"ERROR: {type(exc).__name__}: {exc}",
                "score": None, "planned": None, "wall_time_s": None, "rtf": None}
    plan = report.get("plan") or {}
    return {"seed": seed, "arena": report["arena"], "ok": report["ok"],
            "result": report["result"], "reason": report["reason"],
            "verdict": report["verdict"], "score": report["score"],
            "planned": plan.get("points"), "greedy": (plan.get("greedy") or {}).get("points"),
            "max_score": report["max_score"], "crashed": report["crashed"],
            "landings": len(report["landings"]),
            "inside": sum(d["inside_pad"] for d in report["landings"]),
            "sim_time_s": report["sim_time_s"],
            "wall_time_s": report["host"]["wall_time_s"], "rtf": report["host"]["rtf"]}


def main() -> None:
    parser = bench_parser(__doc__, "mission")
    parser.add_argument("--seeds", default="1-20", help="e.g. 1-20, 3,7 or 2-4,6-20")
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel (processes)")
    parser.add_argument("--runs", type=Path, default=Path("runs/mission_seeds"),
                        help="folder for each run's report.json and pictures")
    parser.add_argument("--merge", nargs="+", type=Path, metavar="PART",
                        help="join these results' runs into --out (no flying)")
    args = parser.parse_args()
    seeds = seed_list(args.seeds)
    if args.merge:
        merged = merge([json.loads(part.read_text()) for part in args.merge], len(seeds))
        write_result(args.out, merged, allow_nan=False)
        print(json.dumps({k: v for k, v in merged.items() if k != "runs"}))
        return
    runs: list[dict[str, Any]] = []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(run_one, args.runs / f"seed_{seed}", seed) for seed in seeds]
        for seed, future in zip(seeds, futures, strict=True):
            runs.append(future.result())
            print(f"seed {seed:2d}: {runs[-1]['verdict']}", flush=True)
            # written after each run: a stopped run keeps these
            write_result(args.out, summary(runs, len(seeds), args.jobs), allow_nan=False)
    print(json.dumps({k: v for k, v in summary(runs, len(seeds), args.jobs).items()
                      if k != "runs"}))


def summary(runs: list[dict[str, Any]], planned_runs: int, jobs: int) -> dict[str, Any]:
    """The benchmark's JSON: success rate, score ratios, wall times, and every run."""
    ratios = [r["score"] / r["planned"] for r in runs if r["planned"]]
    of_max = [r["score"] / r["max_score"] for r in runs if r.get("max_score")]
    walls = [r["wall_time_s"] for r in runs if r["wall_time_s"] is not None]
    rtfs = [r["rtf"] for r in runs if r["rtf"]]
    successes = sum(bool(r["ok"]) for r in runs)
    return {
        "target_successes": f"{TARGET_SUCCESSES}/20",
        "successes": successes, "runs_done": len(runs), "runs_planned": planned_runs,
        "success_rate": round(successes / len(runs), 3) if runs else None,
        "mean_score_ratio": round(float(np.mean(ratios)), 3) if ratios else None,
        "mean_score_of_max": round(float(np.mean(of_max)), 3) if of_max else None,
        "wall_time_s": {"p50": round(float(np.median(walls)), 1) if walls else None,
                        "max": round(max(walls), 1) if walls else None},
        "rtf_p50": round(float(np.median(rtfs)), 3) if rtfs else None,
        "jobs": jobs,
        "runs": runs,
    }


def merge(parts: list[dict[str, Any]], planned_runs: int) -> dict[str, Any]:
    """One result of several parts' runs, by seed (a later part's run of a seed wins)."""
    by_seed = {r["seed"]: r for part in parts for r in part["runs"]}
    jobs = max(int(part.get("jobs", 1)) for part in parts)
    return summary([by_seed[s] for s in sorted(by_seed)], planned_runs, jobs)


if __name__ == "__main__":
    main()
