"""The results page's section for `benchmarks/bench_fcu.py`."""

from __future__ import annotations

from . import Json, Section
from ._markdown import ratio, table


def _fcu(d: Json) -> list[str]:
    rows = [[name, r["rtf_sitl"], f"{r['tick_mean_us']} us", f"{r['tick_max_us']} us",
             ratio(r["tick_mean_over_budget"], 3), r["overruns"], r["functions_per_tick_peak"]]
            for name, r in (("balanced", d["balanced"]), ("naive", d["naive"]))]
    lines = table(["offsets", "SITL RTF", "tick mean", "tick max", "mean / 2000 us budget",
                   "overruns", "peak functions per tick"], rows)
    return [f"{d['sim_seconds']:.0f} s simulated hover.", "", *lines,
            f"Bare world loop RTF {d['rtf_bare_world']}; SITL / bare "
            f"{ratio(d['ratio_sitl_over_bare'], 3)}.", ""]


SECTIONS = {
    "fcu": Section(
        "Simulated FCU: balanced against naive offsets",
        "A hover through the SITL with each offset strategy of the static scheduler. Tick "
        "times are wall clock and move with the host's load (not recorded in this JSON).",
        body=_fcu),
}
