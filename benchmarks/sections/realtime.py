"""The results page's section for `benchmarks/bench_realtime.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import cm, dash, table, yes


def _realtime(d: Json) -> list[str]:
    rows = []
    for way, w in d["ways"].items():
        setpoints = w["setpoints"] or {}
        behind = w["vehicle_behind"] or {}
        rows.append([way, w["result"], yes(w["all_inside"]),
                     dash(w["touchdown_rmse_m"] and cm(w["touchdown_rmse_m"])),
                     f"{w['companion_cpu_s_per_s']:.3f}", dash(setpoints.get("max_gap_s")),
                     dash(behind.get("max_lag_s"))])
    return [f"Budget: the companion at most {d['budget_cpu_s_per_s']:g} CPU-s per second; "
            "the largest setpoint gap under 0.5 s.", ""] + table(
        ["way", "result", "every landing inside", "touchdown RMSE",
         "companion CPU-s per s", "largest setpoint gap [s]", "vehicle's largest lag [s]"],
        rows)


SECTIONS = {
    "realtime": Section(
        "The companion in real time",
        "companion.yaml against `quadmission vehicle` on the wall clock (no lockstep, no "
        "/clock), the whole mission, three ways: both cores, the companion pinned to one "
        "core, a busy process beside it.",
        body=_realtime),
}
