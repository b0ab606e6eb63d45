"""Compare two time-sync estimators on the same seeded synthetic traces.

    python benchmarks/bench_timesync.py --out benchmarks/results/timesync.json

For every scenario of ``flight_control.timesync_traces.SCENARIOS`` and every seed, both
estimators replay the identical trace. Reported per scenario (median over seeds):

* convergence samples: exchanges until the error stays within +/-50 us of its own
  steady-state median (from the clock jump in the jump scenarios); ``never`` if it did not;
* steady-state |estimate - true offset| p50 / p99 [us] over the steady tail;
* bias: median signed error over the tail (mostly path asymmetry, unobservable);
* skew error p99 [ppm];
* ratios baseline / candidate (> 1: the candidate is better).
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import asdict

import numpy as np
from _harness import bench_parser, write_result

from flight_control.timesync import ESTIMATORS, make_estimator
from flight_control.timesync_traces import (
    CONVERGENCE_TOLERANCE_US,
    SCENARIOS,
    ReplayMetrics,
    generate_trace,
    replay,
    replay_metrics,
)


def _median_convergence(values: list[int | None]) -> float:
    """Median with ``never`` (None) counted as infinitely late."""
    return statistics.median(math.inf if v is None else float(v) for v in values)


def _ratio(baseline: float, candidate: float) -> float | None:
    if math.isinf(baseline) and math.isinf(candidate):
        return None
    if candidate == 0.0:
        return math.inf if baseline > 0.0 else 1.0
    return baseline / candidate


def _json_number(x: float | None) -> float | str | None:
    if x is None:
        return None
    return "inf" if math.isinf(x) else round(x, 3)


def run(seeds: list[int], baseline: str, candidate: str) -> dict[str, object]:
    scenarios: dict[str, object] = {}
    for name, scenario in SCENARIOS.items():
        per_estimator: dict[str, list[ReplayMetrics]] = {baseline: [], candidate: []}
        us_per_update: dict[str, list[float]] = {baseline: [], candidate: []}
        for seed in seeds:
            trace = generate_trace(scenario.config, np.random.default_rng(seed))
            for est_name, bucket in per_estimator.items():
                t0 = time.perf_counter()
                result = replay(make_estimator(est_name), trace)
                us_per_update[est_name].append((time.perf_counter() - t0) / len(trace) * 1e6)
                bucket.append(replay_metrics(
                    result, trace, steady_from=scenario.steady_from,
                    segment_start=scenario.segment_start,
                ))
        summary: dict[str, dict[str, float]] = {}
        for est_name, metrics in per_estimator.items():
            summary[est_name] = {
                "convergence_samples": _median_convergence(
                    [m.convergence_samples for m in metrics]),
                "steady_p50_us": statistics.median(m.steady_p50_us for m in metrics),
                "steady_p99_us": statistics.median(m.steady_p99_us for m in metrics),
                "steady_p99_worst_us": max(m.steady_p99_us for m in metrics),
                "bias_us": statistics.median(m.steady_bias_us for m in metrics),
                "jitter_p99_us": statistics.median(m.jitter_p99_us for m in metrics),
                "skew_error_p99_ppm": statistics.median(m.skew_error_p99_ppm for m in metrics),
                "us_per_update": statistics.median(us_per_update[est_name]),
            }
        b, c = summary[baseline], summary[candidate]
        ratios = {
            key: _ratio(b[key], c[key])
            for key in ("convergence_samples", "steady_p50_us", "steady_p99_us",
                        "jitter_p99_us", "skew_error_p99_ppm")
        }
        scenarios[name] = {
            "description": scenario.description,
            "segment_start": scenario.segment_start,
            "steady_from": scenario.steady_from,
            "summary": {k: {m: _json_number(x) for m, x in v.items()} for k, v in summary.items()},
            "ratio_baseline_over_candidate": {k: _json_number(v) for k, v in ratios.items()},
            "per_seed": {
                est_name: [
                    {"seed": s, **{k: _json_number(v) if isinstance(v, float) else v
                                   for k, v in asdict(m).items()}}
                    for s, m in zip(seeds, metrics, strict=True)
                ]
                for est_name, metrics in per_estimator.items()
            },
        }
    return {
        "baseline": baseline,
        "candidate": candidate,
        "seeds": seeds,
        "convergence_tolerance_us": CONVERGENCE_TOLERANCE_US,
        "scenarios": scenarios,
    }


def _fmt(x: object) -> str:
    if x is None:
        return "-"
    if x == "inf":
        return "never"
    assert isinstance(x, int | float)
    return f"{x:.0f}" if abs(x) >= 100 else f"{x:.1f}"


def format_table(report: dict[str, object]) -> str:
    baseline, candidate = str(report["baseline"]), str(report["candidate"])
    head = (f"{'scenario':15s} {'estimator':9s} {'conv[n]':>8s} {'p50[us]':>8s} "
            f"{'p99[us]':>8s} {'bias[us]':>9s} {'skew99[ppm]':>11s}")
    lines = [head, "-" * len(head)]
    scenarios = report["scenarios"]
    assert isinstance(scenarios, dict)
    for name, sc in scenarios.items():
        for est in (baseline, candidate):
            s = sc["summary"][est]
            lines.append(
                f"{name:15s} {est:9s} {_fmt(s['convergence_samples']):>8s} "
                f"{_fmt(s['steady_p50_us']):>8s} {_fmt(s['steady_p99_us']):>8s} "
                f"{_fmt(s['bias_us']):>9s} {_fmt(s['skew_error_p99_ppm']):>11s}"
            )
        r = sc["ratio_baseline_over_candidate"]
        lines.append(
            f"{'':15s} {'ratio':9s} {_fmt(r['convergence_samples']):>8s} "
            f"{_fmt(r['steady_p50_us']):>8s} {_fmt(r['steady_p99_us']):>8s} "
            f"{'':>9s} {_fmt(r['skew_error_p99_ppm']):>11s}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = bench_parser(__doc__, "timesync")
    parser.add_argument("--seeds", type=int, default=5, help="seeds 0..N-1 (default 5)")
    parser.add_argument("--baseline", default="px4", choices=sorted(ESTIMATORS))
    parser.add_argument("--candidate", default="kalman", choices=sorted(ESTIMATORS))
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be >= 1")
    report = run(list(range(args.seeds)), args.baseline, args.candidate)
    write_result(args.out, report)
    print(format_table(report))
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
