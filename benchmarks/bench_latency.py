"""Seed 000's latency test in the SITL against its Table 3 (the baseline), per estimator.

    python benchmarks/bench_latency.py --out benchmarks/results/latency.json

Runs ``quadmission latency`` (:func:`quadmission.experiments.latency.run_latency_experiment`) for
``--duration`` simulated seconds (default 60) and writes its JSON report plus:

- ``vs_table3``: per path (forward = companion -> FCU, reverse = FCU -> companion), Table 3's
  MicroXRCE-DDS - ROS 2 mean +/- sd next to ours, corrected by each estimator and on the
  true clock, with the ratios ours / paper (1.0 is a perfect match). The forward path is
  measured where the FCU's estimator parses the sample (on arrival, as seed 000's
  event-driven bridge), the reverse where the companion node receives it; the link is
  fitted so that these end-to-end figures are Table 3's
  (:func:`quadmission.experiments.latency.fit_link`).
- ``estimators``: offset error p50/p99 of ``px4`` against ``kalman`` on the same exchanges,
  with the ratio px4 / kalman (> 1: kalman tracks the true offset closer).
- ``host``: wall time of the run and the real-time factor (simulated / wall seconds).
"""

from __future__ import annotations

import sys
import time
from typing import Any

from _harness import bench_parser, write_result

from quadmission.experiments.latency import (
    EVENT_DRIVEN_INPUTS,
    TABLE3,
    LatencyConfig,
    LatencyPath,
    LatencyReport,
    LatencyStats,
    format_report,
    run_latency_experiment,
)


def _versus(stats: LatencyStats, path: LatencyPath) -> dict[str, float]:
    paper = TABLE3[path]
    return {
        "mean_us": round(stats.mean_us, 1),
        "sd_us": round(stats.sd_us, 1),
        "ratio_mean": round(stats.mean_us / paper.mean_us, 4),
        "ratio_sd": round(stats.sd_us / paper.sd_us, 4),
    }


def compare(report: LatencyReport) -> dict[str, Any]:
    """Table 3 side by side with the run, and the estimators against each other."""
    vs_table3 = {}
    for path in LatencyPath:
        figures = report.path(path)
        paper = TABLE3[path]
        vs_table3[path.value] = {
            "paper_us": {"mean": paper.mean_us, "sd": paper.sd_us},
            "true_clock": _versus(figures.true, path),
            **{f"corrected_{name}": _versus(stats, path)
               for name, stats in figures.corrected.items()},
        }
    px4, kalman = report.offset_error["px4"], report.offset_error["kalman"]
    return {
        "baseline": "seed 000 Table 3, MicroXRCE-DDS - ROS 2 (mean +/- sd, us)",
        "event_driven_inputs": sorted(EVENT_DRIVEN_INPUTS),
        "vs_table3": vs_table3,
        "estimators": {
            "offset_error_us": {"px4": px4.to_json(), "kalman": kalman.to_json()},
            "ratio_p50_px4_over_kalman": round(px4.p50 / kalman.p50, 3),
            "ratio_p99_px4_over_kalman": round(px4.p99 / kalman.p99, 3),
            "converged_s": {k: round(v, 3) for k, v in report.converged_s.items()},
        },
    }


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, "latency")
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    start = time.perf_counter()
    report = run_latency_experiment(LatencyConfig(duration_s=args.duration, seed=args.seed))
    wall_s = time.perf_counter() - start
    result = {
        **compare(report),
        "host": {"wall_s": round(wall_s, 2), "rtf": round(args.duration / wall_s, 3)},
        "report": report.to_json(),
    }
    write_result(args.out, result)
    print(format_report(report))
    print(f"\nwrote {args.out} ({wall_s:.1f} s wall, "
          f"real-time factor {args.duration / wall_s:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
