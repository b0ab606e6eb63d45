"""The results page's section for `benchmarks/bench_latency.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import num, ratio, table


def _latency(d: Json) -> list[str]:
    rows = []
    for direction, name in (("forward", "companion -> FCU (at the FCU estimator)"),
                            ("reverse", "FCU -> companion (at the companion node)")):
        v = d["vs_table3"][direction]
        paper = v["paper_us"]
        for key, label in (("true_clock", "true clock"), ("corrected_kalman", "kalman-corrected"),
                           ("corrected_px4", "PX4-filter-corrected")):
            rows.append([name, label, f"{v[key]['mean_us']:.0f} +/- {v[key]['sd_us']:.0f} us",
                         f"{paper['mean']:.0f} +/- {paper['sd']:.0f} us",
                         f"{num(v[key]['ratio_mean'], 3)} / {num(v[key]['ratio_sd'], 3)}"])
    lines = table(["path", "clock", "measured", "Table 3", "ratio mean / sd"], rows)
    e = d["estimators"]
    lines += table(["estimator", "offset error p50 / p99 / max", "bias", "converged at"],
                   [[name, f"{e['offset_error_us'][name]['p50']:.0f} / "
                     f"{e['offset_error_us'][name]['p99']:.0f} / "
                     f"{e['offset_error_us'][name]['max']:.0f} us",
                     f"{e['offset_error_us'][name]['bias']:.0f} us",
                     f"{e['converged_s'][name]} s"] for name in ("kalman", "px4")])
    r = d["report"]
    return [f"{r['duration_s']:.0f} s, seed {r['seed']}, {r['payload_bytes']} B at "
            f"{r['rate_hz']:.0f} Hz each way. Baseline: {d['baseline']}.", "", *lines,
            f"PX4 / kalman offset error: p50 {ratio(e['ratio_p50_px4_over_kalman'], 1)}, "
            f"p99 {ratio(e['ratio_p99_px4_over_kalman'], 1)}.", ""]


def _headline(r: Results) -> list[Row]:
    forward, reverse = (r["latency"]["vs_table3"][d]["corrected_kalman"]
                        for d in ("forward", "reverse"))
    return [["FCU <-> companion latency, kalman-corrected: forward / reverse mean",
             f"{forward['mean_us']:.0f} / {reverse['mean_us']:.0f} us",
             f"seed 000 Table 3 (ratio {num(forward['ratio_mean'], 3)}"
             f" / {num(reverse['ratio_mean'], 3)})"]]


SECTIONS = {
    "latency": Section(
        "Latency experiment (seed 000 Table 3)",
        "`quadmission latency`: 200 Hz vision stream companion -> FCU and 200 Hz IMU stream "
        "FCU -> companion, measured at the paper's points with each time-sync estimator's "
        "correction and on the simulator's true clock.",
        body=_latency, headline=_headline),
}
