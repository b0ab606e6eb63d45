"""The results page's section for `benchmarks/bench_navigate_seeds.py`."""

from __future__ import annotations

from . import Json, Results, Row, Section
from ._markdown import span, table


def _navigate_seeds(d: Json) -> list[str]:
    runs = d["runs"]
    lines = table(["figure", "value", "baseline"], [
        ["arenas where every pad was reached with no crash",
         f"{d['all_pads_no_crash']} of {d['total']}", "all"],
        ["smallest clearance to an obstacle", f"{d['min_clearance_m']:.2f} m", "-"],
        ["xy tracking RMSE", span([r["rmse_m"]["xy"] for r in runs], 3, "m"), "-"],
        ["simulated time per flight", span([r["sim_time_s"] for r in runs], 0, "s"), "-"],
        ["graph updates per flight (one build each)",
         span([r["graph_updates"] for r in runs], 0), "-"],
        ["wall time per flight", span([r["wall_time_s"] for r in runs], 0, "s"),
         "moves with the host's load"],
    ])
    lines += table(["seed", "arena", "verdict", "min clearance", "xy RMSE", "simulated s"],
                   [[r["seed"], r["arena"], r["verdict"], f"{r['min_clearance_m']:.2f} m",
                     f"{r['rmse_m']['xy']:.3f} m", f"{r['sim_time_s']:.0f}"] for r in runs])
    return lines


def _headline(r: Results) -> list[Row]:
    nav = r["navigate_seeds"]
    return [["navigate: every pad reached, no crash (default + random arenas)",
             f"{nav['all_pads_no_crash']} of {nav['total']}, min clearance "
             f"{nav['min_clearance_m']:.2f} m", "all"]]


SECTIONS = {
    "navigate_seeds": Section(
        "Navigate scenario on 11 arenas",
        "From the start pad to every other pad in a seeded order, each leg planned by A* on "
        "the live depth map and flown by the navigator, on the default arena and random "
        "arenas.",
        body=_navigate_seeds, headline=_headline),
}
