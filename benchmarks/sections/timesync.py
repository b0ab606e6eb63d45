"""The results page's section for `benchmarks/bench_timesync.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import ratio, table


def _timesync(d: Json) -> list[str]:
    rows = []
    for name, s in d["scenarios"].items():
        k, p = s["summary"][d["candidate"]], s["summary"][d["baseline"]]
        rows.append([f"{name}: {s['description']}",
                     f"{k['convergence_samples']:.0f} vs {p['convergence_samples']:.0f}",
                     f"{k['steady_p99_us']:.0f} vs {p['steady_p99_us']:.0f} us",
                     f"{k['skew_error_p99_ppm']:.2f} vs {p['skew_error_p99_ppm']:.2f} ppm",
                     ratio(s["ratio_baseline_over_candidate"]["convergence_samples"], 1),
                     ratio(s["ratio_baseline_over_candidate"]["steady_p99_us"])])
    lines = table(["trace", "samples to converge", "steady error p99", "skew error p99",
                   "PX4 / ours: convergence", "PX4 / ours: p99 error"], rows)
    return [f"Ours (`{d['candidate']}`) against PX4's filter (`{d['baseline']}`) on the same "
            f"traces, seeds {', '.join(map(str, d['seeds']))}; converged = within "
            f"{d['convergence_tolerance_us']:.0f} us.", "", *lines]


def _headline(r: Results) -> list[Row]:
    ts = r["timesync"]["scenarios"]["nominal"]["summary"]
    return [["time sync, samples to converge: our Kalman vs PX4's filter",
             f"{ts['kalman']['convergence_samples']:.0f} vs "
             f"{ts['px4']['convergence_samples']:.0f}", "same traces"]]


SECTIONS = {
    "timesync": Section(
        "Time sync: our Kalman filter against PX4's",
        "Offset estimation on recorded exchange traces, several disturbances.",
        body=_timesync, headline=_headline),
}
