"""Campaign throughput: missions per CPU-hour, and 2 workers against 1 on this machine.

    python benchmarks/bench_campaign.py --out benchmarks/results/campaign.json
    python benchmarks/bench_campaign.py --seeds 2,7 --rounds 1 --out /tmp/campaign.json

One campaign of short clean square flights (``quadmission sim --scenario square`` on the
random arenas with the smallest squares: seeds 2, 3 and 7, 2-2.75 m sides, 35-41 s of
simulated flight; light and dark) runs through the campaign runner
(:func:`quadmission.campaigns.runner.run_campaign`) on a local Dask cluster of 1 worker
process and on one of 2, each into a fresh folder, the two alternated over ``--rounds``.
The clusters are started, and their workers have imported the runner, before the clock
starts (a fixed 2-10 s a campaign pays once).

- ``missions_per_cpu_hour``: runs per hour of the runs' own CPU time (each run's process,
  user + system, from ``wait4``), interpreter start included: what a mission costs
  wherever it runs;
- ``runs_per_hour``: runs per hour of wall time, submission to the last row, per worker
  count; ``ratio_2_over_1``: 2 workers' against 1's, in each round (the same minutes of
  the machine), and their median. 2.0 is perfect scaling on 2 free cores; the machine is
  shared, so the JSON records the 1-minute load before and after, and each side's
  ``cpu_share_per_run`` (a run's CPU seconds per wall second: how much of a core the
  neighbours left it) and ``runner_overhead_s`` (the campaign's wall time beyond its runs'
  own, spread over the workers).

A short square is a mission of the campaign's smallest kind: the interpreter's start
(about 2 s of CPU) weighs more here than in a 5-15 minute contest mission.
"""

from __future__ import annotations

import importlib
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")
# measure the checkout this file is in (a worktree), not whatever the venv has installed
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _harness import bench_parser, host, load_1min, write_result
from distributed import Client, LocalCluster

from quadmission.campaigns.matrix import Campaign, Cell
from quadmission.campaigns.runner import run_campaign
from sim.arena import Lighting

S_PER_HOUR = 3600.0


def campaign(seeds: list[int]) -> Campaign:
    cells = tuple(Cell("square", seed, None, light, ())
                  for seed in seeds for light in (Lighting.LIGHT, Lighting.DARK))
    return Campaign("bench-square", cells, timeout_s=900.0)


def one_side(plan: Campaign, workers: int, folder: Path) -> dict[str, Any]:
    """Run ``plan`` on a fresh local cluster of ``workers`` processes."""
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        client.run(importlib.import_module, "quadmission.campaigns.runner")  # a fixed cost
        started = time.monotonic()
        result = run_campaign(plan, folder, source="benchmarks/bench_campaign.py",
                              scheduler=cluster.scheduler_address, progress=False)
        wall_s = time.monotonic() - started
    rows = result.rows
    cpu_s = sum(r["cpu_s"] for r in rows)
    runs_wall_s = sum(r["wall_s"] for r in rows)
    return {"workers": workers, "runs": len(rows), "passed": sum(r["passed"] for r in rows),
            "wall_s": round(wall_s, 2), "cpu_s": round(cpu_s, 2),
            # the runs' own wall time spread over the workers, against the campaign's: what
            # the runner adds between runs (Dask, rows, the summary and plots at the end)
            "runs_wall_s": round(runs_wall_s, 2),
            "runner_overhead_s": round(wall_s - runs_wall_s / workers, 2),
            "cpu_share_per_run": round(cpu_s / runs_wall_s, 3),
            "runs_per_hour": round(len(rows) * S_PER_HOUR / wall_s, 1),
            "missions_per_cpu_hour": round(len(rows) * S_PER_HOUR / cpu_s, 1),
            "run_wall_s_p50": round(statistics.median(r["wall_s"] for r in rows), 2)}


def main() -> None:
    parser = bench_parser(__doc__, "campaign")
    parser.add_argument("--seeds", default="2,3,7", help="random arenas, e.g. 2,3,7")
    parser.add_argument("--rounds", type=int, default=2,
                        help="1 worker then 2, this many times")
    args = parser.parse_args()
    plan = campaign([int(s) for s in args.seeds.split(",")])
    load_before = load_1min()
    rounds = []
    with tempfile.TemporaryDirectory(prefix="bench_campaign_") as tmp:
        for i in range(args.rounds):
            pair = {}
            for workers in (1, 2):
                side = one_side(plan, workers, Path(tmp) / f"r{i}_w{workers}")
                print(json.dumps(side), flush=True)
                pair[workers] = side
            rounds.append({"one_worker": pair[1], "two_workers": pair[2],
                           "ratio_2_over_1": round(pair[2]["runs_per_hour"]
                                                   / pair[1]["runs_per_hour"], 3)})
    sides = [r[k] for r in rounds for k in ("one_worker", "two_workers")]
    result = {
        "campaign": f"square, clean, random arenas {args.seeds}, light and dark: "
                    f"{len(plan.cells)} runs a side",
        "missions_per_cpu_hour": round(statistics.median(
            s["missions_per_cpu_hour"] for s in sides), 1),
        "runs_per_hour_one_worker": [r["one_worker"]["runs_per_hour"] for r in rounds],
        "runs_per_hour_two_workers": [r["two_workers"]["runs_per_hour"] for r in rounds],
        "ratio_2_over_1": round(statistics.median(r["ratio_2_over_1"] for r in rounds), 3),
        "ratio_2_over_1_rounds": [r["ratio_2_over_1"] for r in rounds],
        "all_passed": all(s["passed"] == s["runs"] for s in sides),
        "rounds": rounds,
        "host": host(load_1min=load_before, load_1min_after=load_1min()),
    }
    write_result(args.out, result, allow_nan=False)
    print(json.dumps({k: v for k, v in result.items() if k != "rounds"}))


if __name__ == "__main__":
    main()
